#include "server/http/problem.h"

namespace tessera::server {

int http_status(QueueErrorKind kind) {
    switch (kind) {
        case QueueErrorKind::invalid: return 400;
        case QueueErrorKind::not_found: return 404;
        case QueueErrorKind::conflict: return 409;
        case QueueErrorKind::gone: return 410;
        case QueueErrorKind::broken_file: return 422;
        case QueueErrorKind::queue_full: return 429;
        case QueueErrorKind::store_full: return 507;
        case QueueErrorKind::unavailable: return 503;
    }
    return 500;
}

Problem problem(const QueueError& e) {
    Problem p(http_status(e.kind), e.code, e.title, e.what());
    p.field = e.field;
    p.location = e.location;
    p.retry_after = e.retry_after_s;
    return p;
}

}  // namespace tessera::server
