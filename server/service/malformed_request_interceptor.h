#ifndef EXCITE_SERVER_SERVICE_MALFORMED_REQUEST_INTERCEPTOR_H_
#define EXCITE_SERVER_SERVICE_MALFORMED_REQUEST_INTERCEPTOR_H_

#include <memory>

#include "grpcpp/support/server_interceptor.h"

namespace excite::service {

// gRPC answers a unary request it cannot parse (malformed protobuf bytes, or a
// string field that is not UTF-8) with INTERNAL and an empty message, which
// reads as a bug of the server. This interceptor sends INVALID_ARGUMENT saying
// what happened instead. (In a stream, gRPC ends the server's reading at such a
// message exactly as at the client's end of the stream, and no interceptor can
// tell the two apart: see docs/api.md.)
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>
MakeMalformedRequestInterceptorFactory();

}  // namespace excite::service

#endif  // EXCITE_SERVER_SERVICE_MALFORMED_REQUEST_INTERCEPTOR_H_
