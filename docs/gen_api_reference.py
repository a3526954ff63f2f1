#!/usr/bin/python3
"""Reference docs of the excite API from the comments in proto/excite/v1/*.proto.

    /usr/bin/python3 docs/gen_api_reference.py            # writes docs/api-reference.md
    /usr/bin/python3 docs/gen_api_reference.py --check    # lists elements without a comment

Runs Debian's protoc with --include_source_info and reads the comments from the
descriptor set (leading or trailing comments count). --check exits 1 if any service,
method, message, field, enum or enum value has no comment, or if the file is stale.
The table of SessionConfig's numbers comes from the server's own rules
(server/service/config_rules.cc, printed by `excite-config-rules`), so the build must
exist (--rules_bin, default build/release/server/excite-config-rules).
"""

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile

from google.protobuf import descriptor_pb2

REPO = pathlib.Path(__file__).resolve().parents[1]
PROTO_ROOT = REPO / "proto"
FILES = ["excite/v1/exploration_service.proto", "excite/v1/session_config.proto",
         "excite/v1/sim_config.proto"]
# FileDescriptorProto / DescriptorProto / ... field numbers used in source paths.
MESSAGE, ENUM, SERVICE = 4, 5, 6
FIELD, NESTED, NESTED_ENUM = 2, 3, 4
VALUE, METHOD = 2, 2
LABEL = {1: "optional", 2: "required", 3: "repeated"}
TYPE = {
    1: "double", 2: "float", 3: "int64", 4: "uint64", 5: "int32", 8: "bool", 9: "string",
    12: "bytes", 13: "uint32", 15: "sfixed32", 16: "sfixed64", 17: "sint32", 18: "sint64",
    6: "fixed64", 7: "fixed32",
}


def descriptor_set(root):
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "set.pb")
        subprocess.run(["protoc", f"--proto_path={root}", "--include_source_info",
                        f"--descriptor_set_out={out}", *FILES], check=True)
        result = descriptor_pb2.FileDescriptorSet()
        result.ParseFromString(pathlib.Path(out).read_bytes())
        return result


def comment(comments, path):
    loc = comments.get(tuple(path))
    if loc is None:
        return ""
    text = (loc.leading_comments or loc.trailing_comments).strip()
    return " ".join(line.strip() for line in text.splitlines())


class Walker:
    def __init__(self):
        self.missing = []
        self.lines = []

    def enum(self, comments, enum, path, prefix):
        name = prefix + enum.name
        doc = comment(comments, path)
        if not doc:
            self.missing.append(f"enum {name}")
        self.lines += [f"### enum `{name}`", "", doc, "", "| value | number | description |",
                       "| --- | --- | --- |"]
        for i, value in enumerate(enum.value):
            vdoc = comment(comments, path + [VALUE, i])
            if not vdoc:
                self.missing.append(f"enum value {name}.{value.name}")
            self.lines.append(f"| `{value.name}` | {value.number} | {vdoc} |")
        self.lines.append("")

    def message(self, comments, message, path, prefix):
        name = prefix + message.name
        doc = comment(comments, path)
        if not doc:
            self.missing.append(f"message {name}")
        self.lines += [f"### message `{name}`", "", doc, ""]
        if message.field:
            self.lines += ["| field | type | description |", "| --- | --- | --- |"]
        # A map<K, V> field is a repeated synthetic XEntry message: shown as the map.
        entries = {f"{name}.{m.name}": m for m in message.nested_type if m.options.map_entry}
        for i, field in enumerate(message.field):
            fdoc = comment(comments, path + [FIELD, i])
            if not fdoc:
                self.missing.append(f"field {name}.{field.name}")
            kind = field.type_name.rsplit(".", 1)[-1] if field.type_name else TYPE.get(
                field.type, str(field.type))
            label = "repeated " if field.label == 3 else ""
            entry = entries.get(field.type_name.lstrip(".").split(".", 2)[-1])
            if entry is not None:
                key, value = (TYPE.get(f.type, str(f.type)) for f in entry.field)
                kind, label = f"map<{key}, {value}>", ""
            self.lines.append(f"| `{field.name}` = {field.number} | {label}`{kind}` | {fdoc} |")
        self.lines.append("")
        for i, nested in enumerate(message.nested_type):
            if not nested.options.map_entry:
                self.message(comments, nested, path + [NESTED, i], name + ".")
        for i, enum in enumerate(message.enum_type):
            self.enum(comments, enum, path + [NESTED_ENUM, i], name + ".")

    def file(self, f):
        comments = {tuple(loc.path): loc for loc in f.source_code_info.location}
        self.lines += [f"## `{f.name}`", ""]
        for i, service in enumerate(f.service):
            doc = comment(comments, [SERVICE, i])
            if not doc:
                self.missing.append(f"service {service.name}")
            self.lines += [f"### service `{service.name}`", "", doc, "",
                           "| method | request | response | description |",
                           "| --- | --- | --- | --- |"]
            for j, method in enumerate(service.method):
                mdoc = comment(comments, [SERVICE, i, METHOD, j])
                if not mdoc:
                    self.missing.append(f"rpc {service.name}.{method.name}")
                stream_in = "stream " if method.client_streaming else ""
                stream_out = "stream " if method.server_streaming else ""
                self.lines.append(
                    f"| `{method.name}` | {stream_in}`{method.input_type.rsplit('.', 1)[-1]}` "
                    f"| {stream_out}`{method.output_type.rsplit('.', 1)[-1]}` | {mdoc} |")
            self.lines.append("")
        for i, message in enumerate(f.message_type):
            self.message(comments, message, [MESSAGE, i], "")
        for i, enum in enumerate(f.enum_type):
            self.enum(comments, enum, [ENUM, i], "")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--check", action="store_true")
    parser.add_argument("--out", default=str(REPO / "docs" / "api-reference.md"))
    parser.add_argument("--proto_root", default=str(PROTO_ROOT))
    parser.add_argument("--rules_bin",
                        default=str(REPO / "build" / "release" / "server" /
                                    "excite-config-rules"))
    args = parser.parse_args()
    walker = Walker()
    files = {f.name: f for f in descriptor_set(args.proto_root).file}
    for name in FILES:  # the service first, then the config schemas
        walker.file(files[name])
    header = ["# excite API reference", "",
              "Generated by `docs/gen_api_reference.py` from the comments in "
              "`proto/excite/v1/`; do not edit. Worked examples: [api.md](api.md).", ""]
    rules = subprocess.run([args.rules_bin], check=True, capture_output=True,
                           text=True).stdout
    numbers = ["## SessionConfig numbers", "",
               "The numbers whose 0 (unset) means a default, from the server's own rules "
               "(`server/service/config_rules.cc`): a 0 is read as the default; the default "
               "is written into the stored config of the sessions it is filled in for; any "
               "other value outside the range is INVALID_ARGUMENT naming the field.", ""]
    text = ("\n".join(header + walker.lines).rstrip() + "\n\n" + "\n".join(numbers) +
            "\n" + rules)
    if args.check:
        for item in walker.missing:
            print(f"no comment: {item}")
        print(f"{len(walker.missing)} elements without a comment")
        stale = pathlib.Path(args.out).read_text() != text
        if stale:
            print(f"{args.out} is stale: run docs/gen_api_reference.py")
        return 1 if walker.missing or stale else 0
    pathlib.Path(args.out).write_text(text)
    print(f"wrote {args.out} ({len(walker.missing)} elements without a comment)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
