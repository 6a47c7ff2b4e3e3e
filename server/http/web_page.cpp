// The web page: GET / and GET /ui/NAME serve the files of web/ compiled into the binary. The
// page holds no data and needs no token; it talks to the public API like any client (so it
// works against an API node of a farm as well).
#include <cstring>
#include <string>
#include <string_view>

#include <httplib.h>

#include "server/http/http_api.h"
#include "server/http/problem.h"
#include "server/http/web_assets.h"

namespace tessera::server {
namespace {

const WebAsset* find_asset(std::string_view name) {
    for (const WebAsset* a = web_assets(); a->name; ++a)
        if (name == a->name) return a;
    return nullptr;
}

const char* content_type(std::string_view name) {
    auto ends = [&](std::string_view ext) { return name.size() >= ext.size() && name.substr(name.size() - ext.size()) == ext; };
    if (ends(".html")) return "text/html; charset=utf-8";
    if (ends(".js")) return "text/javascript; charset=utf-8";
    if (ends(".css")) return "text/css; charset=utf-8";
    if (ends(".svg")) return "image/svg+xml";
    if (ends(".png")) return "image/png";
    if (ends(".json")) return "application/json";
    return "application/octet-stream";
}

void send_asset(const WebAsset& a, httplib::Response& res) {
    // Nothing from other hosts, no framing by other sites; images and a shot's preview video
    // may be blob: URLs made from responses fetched with a token.
    res.set_header("Content-Security-Policy",
                   "default-src 'self'; img-src 'self' blob: data:; media-src 'self' blob:; style-src 'self' 'unsafe-inline'; "
                   "script-src 'self'; connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("Referrer-Policy", "no-referrer");
    // The files change with the binary: browsers check again rather than keep an old page.
    res.set_header("Cache-Control", "no-cache");
    res.set_content(std::string(reinterpret_cast<const char*>(a.data), a.size), content_type(a.name));
}

}  // namespace

void HttpApi::page_routes() {
    server_->Get("/", [](const httplib::Request&, httplib::Response& res) {
        const WebAsset* a = find_asset("index.html");
        if (!a) throw Problem(404, "not-found", "Not found", "this binary was built without its web page");
        send_asset(*a, res);
    });
    server_->Get(R"(/ui/([A-Za-z0-9_.-]+))", [](const httplib::Request& req, httplib::Response& res) {
        const std::string name = req.matches[1];
        const WebAsset* a = find_asset(name);
        if (!a) throw Problem(404, "not-found", "Not found", "the web page has no file " + name);
        send_asset(*a, res);
    });
}

}  // namespace tessera::server
