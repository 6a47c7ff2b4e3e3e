#include "server/http/response_bytes.h"

#include <httplib.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <stdexcept>

#include "server/http/problem.h"

namespace tessera::server {
namespace {

// Files up to this size are answered from memory (compressed by httplib where the client
// accepts it); larger ones are streamed.
constexpr uint64_t kInMemory = 256 << 10;

// The Range hold_range took aside for this thread's request.
thread_local std::optional<httplib::Range> t_range;

// Fits the range held for this request (if any) to a body of `size` bytes and gives it back to
// the request: an open or overlong end is cut at the body's, a start at or past it is 416.
void fit_range(const httplib::Request& req, httplib::Response& res, uint64_t size) {
    if (!t_range) return;
    int64_t first = t_range->first, last = t_range->second;
    t_range.reset();
    const int64_t n = int64_t(size);
    if (first < 0) {  // the last `last` bytes
        if (last <= 0) last = 0;
        first = std::max<int64_t>(0, n - last);
        last = n - 1;
    } else if (last < 0 || last >= n) {
        last = n - 1;
    }
    if (n == 0 || first >= n || first > last) {
        res.set_header("Content-Range", "bytes */" + std::to_string(size));
        throw Problem(416, "range-not-satisfiable", "Range not satisfiable",
                      "the range asked for starts past the end of the " + std::to_string(size) + "-byte answer");
    }
    // httplib's Request is not const where it is made; the handler sees it so.
    const_cast<httplib::Request&>(req).ranges = {{first, last}};
}

}  // namespace

void hold_range(httplib::Request& req) {
    t_range.reset();
    if (req.ranges.size() == 1 && !req.has_header("If-Range")) t_range = req.ranges.front();
    req.ranges.clear();
}

void send_file(const httplib::Request& req, httplib::Response& res, const std::string& path, const std::string& content_type) {
    auto in = std::make_shared<std::ifstream>(path, std::ios::binary | std::ios::ate);
    if (!*in) throw std::runtime_error(path + ": cannot be read");
    const std::streamoff end = in->tellg();
    if (end < 0) throw std::runtime_error(path + ": cannot be read");
    const uint64_t size = uint64_t(end);  // of the file opened, whatever the path names later
    fit_range(req, res, size);
    if (size <= kInMemory) {
        std::string body(size, '\0');
        in->seekg(0);
        in->read(body.data(), std::streamsize(size));
        body.resize(size_t(in->gcount()));
        res.set_content(std::move(body), content_type);
        return;
    }
    res.set_content_provider(size_t(size), content_type, [in, size](size_t offset, size_t length, httplib::DataSink& sink) {
        if (offset >= size) return false;
        char buf[64 << 10];
        in->clear();
        in->seekg(std::streamoff(offset));
        in->read(buf, std::streamsize(std::min<uint64_t>({length, size - offset, sizeof buf})));
        const std::streamsize got = in->gcount();
        // A file cut short under the answer (truncated in place) ends the connection.
        return got > 0 && sink.write(buf, size_t(got));
    });
}

bool EncodedResponses::send(const httplib::Request& req, httplib::Response& res, uint64_t estimate,
                            const std::function<std::vector<unsigned char>()>& encode, const std::string& content_type) {
    const std::shared_ptr<State> state = state_;
    uint64_t now = state->held.load();
    do {
        if (now > 0 && now + estimate > state->budget) return false;
    } while (!state->held.compare_exchange_weak(now, now + estimate));
    std::shared_ptr<const std::vector<unsigned char>> bytes;
    {
        // The reservation is given back on every path; the bytes' own size is held from the
        // moment the shared bytes own it, and given back by their deleter.
        std::unique_ptr<std::vector<unsigned char>> encoded;
        try {
            encoded = std::make_unique<std::vector<unsigned char>>(encode());
        } catch (...) {
            state->held -= estimate;
            throw;
        }
        const uint64_t size = encoded->size();
        state->held += size;
        state->held -= estimate;
        // Should the control block fail to allocate, the deleter runs (and gives `size` back).
        bytes = std::shared_ptr<const std::vector<unsigned char>>(encoded.release(), [state, size](const std::vector<unsigned char>* p) {
            delete p;
            state->held -= size;
        });
    }
    fit_range(req, res, bytes->size());
    if (bytes->empty()) {
        res.set_content("", content_type);
        return true;
    }
    res.set_content_provider(bytes->size(), content_type, [bytes](size_t offset, size_t length, httplib::DataSink& sink) {
        if (offset >= bytes->size()) return false;
        const size_t n = std::min({length, bytes->size() - offset, size_t(1) << 20});
        return sink.write(reinterpret_cast<const char*>(bytes->data()) + offset, n);
    });
    return true;
}

}  // namespace tessera::server
