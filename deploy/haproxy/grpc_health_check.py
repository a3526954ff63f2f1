#!/usr/bin/python3
"""Prints the bytes of haproxy.cfg's health check, in hex (tcp-check send-binary).

HAProxy 2.6 cannot send a gRPC request from its HTTP checks (the body would need
NUL bytes), so the check speaks HTTP/2 itself over TCP: the client preface, an
empty SETTINGS frame, one HEADERS frame for POST /grpc.health.v1.Health/Check and
one DATA frame carrying an empty HealthCheckRequest (5 bytes: not compressed,
length 0). Headers are HPACK literals without indexing and without Huffman
coding, so the bytes never depend on the connection's state. A serving replica
answers a DATA frame whose payload is 00 00 00 00 02 08 01 (HealthCheckResponse
{status: SERVING}); haproxy.cfg expects exactly that (a draining replica answers
08 02, NOT_SERVING, and is taken out of the rotation).

Run: deploy/haproxy/grpc_health_check.py   (tests/container/test_manifests.py checks
that haproxy.cfg holds its output).
"""
import struct

PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
FRAME_DATA, FRAME_HEADERS, FRAME_SETTINGS = 0x0, 0x1, 0x4
END_STREAM, END_HEADERS = 0x1, 0x4


def frame(kind: int, flags: int, stream: int, payload: bytes) -> bytes:
    return struct.pack(">I", len(payload))[1:] + bytes([kind, flags]) + \
        struct.pack(">I", stream) + payload


def literal(value: bytes, name_index: int = 0, name: bytes = b"") -> bytes:
    """HPACK literal header field without indexing (RFC 7541 6.2.2), no Huffman."""
    assert name_index < 15 and len(name) < 127 and len(value) < 127
    head = bytes([name_index]) if name_index else b"\x00" + bytes([len(name)]) + name
    return head + bytes([len(value)]) + value


HEADERS = (b"\x83"  # :method POST (static table 3)
           + b"\x86"  # :scheme http (static table 6)
           + literal(b"/grpc.health.v1.Health/Check", name_index=4)  # :path
           + literal(b"localhost", name_index=1)  # :authority
           + literal(b"application/grpc", name=b"content-type")
           + literal(b"trailers", name=b"te"))
REQUEST = (PREFACE + frame(FRAME_SETTINGS, 0, 0, b"")
           + frame(FRAME_HEADERS, END_HEADERS, 1, HEADERS)
           + frame(FRAME_DATA, END_STREAM, 1, b"\x00\x00\x00\x00\x00"))
SERVING_REPLY = b"\x00\x00\x00\x00\x02\x08\x01"

if __name__ == "__main__":
    print(REQUEST.hex())
