#include "server/http/response_bytes.h"

#include <httplib.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace tessera::server {

void send_file(httplib::Response& res, const std::string& path, const std::string& content_type) {
    auto in = std::make_shared<std::ifstream>(path, std::ios::binary);
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    if (!*in || ec) throw std::runtime_error(path + ": cannot be read");
    res.set_content_provider(size_t(size), content_type, [in](size_t offset, size_t length, httplib::DataSink& sink) {
        char buf[64 << 10];
        in->clear();
        in->seekg(std::streamoff(offset));
        in->read(buf, std::streamsize(std::min(length, sizeof buf)));
        const std::streamsize got = in->gcount();
        // A file that shrank under the response (results deleted meanwhile) ends the connection.
        return got > 0 && sink.write(buf, size_t(got));
    });
}

bool EncodedResponses::send(httplib::Response& res, uint64_t estimate, const std::function<std::vector<unsigned char>()>& encode,
                            const std::string& content_type) {
    const std::shared_ptr<State> state = state_;
    uint64_t now = state->held.load();
    do {
        if (now > 0 && now + estimate > state->budget) return false;
    } while (!state->held.compare_exchange_weak(now, now + estimate));
    std::shared_ptr<const std::vector<unsigned char>> bytes;
    try {
        auto encoded = std::make_unique<std::vector<unsigned char>>(encode());
        const uint64_t size = encoded->size();
        // The reservation becomes the bytes' own size; the deleter gives it back when the last
        // copy of the response is gone.
        state->held += size;
        state->held -= estimate;
        bytes = std::shared_ptr<const std::vector<unsigned char>>(encoded.release(), [state, size](const std::vector<unsigned char>* p) {
            delete p;
            state->held -= size;
        });
    } catch (...) {
        state->held -= estimate;
        throw;
    }
    res.set_content_provider(bytes->size(), content_type, [bytes](size_t offset, size_t length, httplib::DataSink& sink) {
        const size_t n = std::min(length, size_t(1) << 20);
        return sink.write(reinterpret_cast<const char*>(bytes->data()) + offset, n);
    });
    return true;
}

}  // namespace tessera::server
