#!/usr/bin/env bash
# hostile_rss.sh [TESSERA]: sends a running server every hostile input of docs/reliability.md,
# one class at a time, and prints a Markdown table: the answers it got, and the server's resident
# memory before, at its peak during the input, and after. Then it waits a minute and prints the
# idle RSS against the start. The server is started here, on a free loopback port with a
# temporary data directory, as `tessera serve` with its defaults (plus TESSERA_SERVE_ARGS).
# Needs curl and python3 (for the PNG bombs and raw sockets). Loopback only.
set -euo pipefail
bin=${1:-build/release/cli/tessera}
command -v python3 > /dev/null || { echo "hostile_rss.sh needs python3" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'kill $pid 2> /dev/null; wait 2> /dev/null; rm -rf "$tmp"' EXIT
port=$((20000 + RANDOM % 40000))
# shellcheck disable=SC2086
"$bin" serve --port "$port" --data-dir "$tmp/data" ${TESSERA_SERVE_ARGS:-} > "$tmp/server.log" 2>&1 &
pid=$!
url=http://127.0.0.1:$port
for _ in $(seq 1 100); do curl -sf "$url/healthz" > /dev/null && break; sleep 0.1; done

kib() { awk -v k="$1" '$1 == k":" {print $2}' "/proc/$pid/status"; }
mb() { echo $(( $1 / 1024 )); }
alive() { curl -s -m 5 -o /dev/null -w '%{http_code}' "$url/healthz" || true; }
statuses() { sort | uniq -c | awk '{printf "%s%s×%s", (NR > 1 ? ", " : ""), $1, $2}'; }

python3 - "$tmp" <<'EOF'
import base64, json, struct, sys, zlib, array
def png(w, h):
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    c = zlib.compressobj(9); row = b"\0" * (w * 4 + 1)
    idat = b"".join(c.compress(row) for _ in range(h)) + c.flush()
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
def gltf(image):
    buf = array.array('f', [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1]).tobytes()
    return json.dumps({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}], "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(image).decode()}],
        "buffers": [{"byteLength": 60, "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}]})
d = sys.argv[1]
open(d + "/bomb16k.gltf", "w").write(gltf(png(16384, 16384)))
open(d + "/tex6k.gltf", "w").write(gltf(png(6000, 6000)))
deep = '{"a":' * 100000 + '1' + '}' * 100000
open(d + "/deep_job.json", "w").write('{"scene":"builtin:cornell_box","adaptive":' + deep + '}')
open(d + "/deep_cmp.json", "w").write('{"scene":"builtin:cornell_box","configs":[' + deep + ']}')
open(d + "/deep.gltf", "w").write('{"asset":{"version":"2.0"},"extras":' + deep + '}')
open(d + "/utf8.gltf", "wb").write(b'{"asset":{"version":"\xff"}}')
open(d + "/png.gltf", "wb").write(b"\x89PNG\r\n\x1a\n" + b"\xff" * 61)
open(d + "/url.dae", "wb").write(b'<?xml version="1.0"?><COLLADA version="1.4.1"><library_visual_scenes><visual_scene id="s"><node>'
    b'<instance_geometry url="#\xff"/></node></visual_scene></library_visual_scenes><scene><instance_visual_scene url="#s"/></scene></COLLADA>')
EOF

# raw.py N REQUEST...: sends the requests on one connection (pipelined), prints each answer's status.
cat > "$tmp/raw.py" <<'EOF'
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1]))); s.settimeout(8)
s.sendall(b"".join(a.encode("latin-1").decode("unicode_escape").encode("latin-1") for a in sys.argv[2:]))
s.shutdown(socket.SHUT_WR)
out = b""
try:
    while True:
        b = s.recv(65536)
        if not b: break
        out += b
except OSError: pass
for part in out.split(b"HTTP/1.1 ")[1:]: print(part[:3].decode())
EOF

echo "| input | answers | RSS before (MB) | peak (MB) | after (MB) | still serving |"
echo "|---|---|---|---|---|---|"
start_rss=$(kib VmRSS)
row() {  # row NAME COMMAND...: COMMAND prints one status code per answer
  local name=$1; shift
  local before peak after answers
  before=$(kib VmRSS)
  echo 5 > "/proc/$pid/clear_refs" 2> /dev/null || true  # peak measured from here (VmHWM reset)
  answers=$("$@" 2> /dev/null | statuses)
  sleep 6  # the server returns free memory every 5 s
  peak=$(kib VmHWM)
  after=$(kib VmRSS)
  echo "| $name | $answers | $(mb "$before") | $(mb "$peak") | $(mb "$after") | $(alive) |"
}
paths() {
  for p in /%ff /ui/%ff /healthz%ff /v1/jobs/%ff /v1/jobs/%ff%fe/report.json "/v1/events?job=%ff" /v1/jobs?state=%ff; do
    curl -s -m 5 -o /dev/null -w '%{http_code}\n' "$url$p"
  done
  for m in DELETE PUT PATCH; do curl -s -m 5 -o /dev/null -w '%{http_code}\n' -X "$m" "$url/v1/jobs/%ff"; done
}
uploads() {
  for f in utf8.gltf png.gltf url.dae deep.gltf; do
    curl -s -m 30 -o /dev/null -w '%{http_code}\n' -X POST "$url/v1/scenes?name=$f" --data-binary "@$tmp/$f"
  done
}
deep() {
  curl -s -m 30 -o /dev/null -w '%{http_code}\n' -X POST "$url/v1/jobs" -H 'Content-Type: application/json' --data-binary "@$tmp/deep_job.json"
  curl -s -m 30 -o /dev/null -w '%{http_code}\n' -X POST "$url/v1/comparisons" -H 'Content-Type: application/json' --data-binary "@$tmp/deep_cmp.json"
}
# An endless chunked body (1 GiB offered): curl -T - streams stdin chunked.
chunked() {
  local path=$1 n=$2
  for _ in $(seq 1 "$n"); do
    head -c 1G /dev/zero | curl -s -m 60 -o /dev/null -w '%{http_code}\n' -X POST -T - -H 'Content-Type: application/json' "$url$path" &
  done
  wait
}
bombs() {
  for _ in $(seq 1 "$1"); do
    curl -s -m 60 -o /dev/null -w '%{http_code}\n' -X POST "$url/v1/scenes?name=bomb.gltf" --data-binary "@$tmp/bomb16k.gltf" &
  done
  wait
}
textured_job() {
  local id scene
  scene=$(curl -s -X POST "$url/v1/scenes?name=tex6k.gltf" --data-binary "@$tmp/tex6k.gltf" -w '\n%{http_code}' | tee "$tmp/up.txt" | tail -n 1)
  echo "$scene"
  scene=$(head -n 1 "$tmp/up.txt" | sed -n 's/.*"id":"\([^"]*\)".*/\1/p')
  id=$(curl -s -X POST "$url/v1/jobs" -H 'Content-Type: application/json' \
       -d "{\"scene\":\"$scene\",\"width\":64,\"height\":48}" | sed -n 's/.*"id":"\([^"]*\)".*/\1/p')
  for _ in $(seq 1 300); do
    curl -s "$url/v1/jobs/$id" | grep -q '"state":"succeeded"' && { echo 200; return; }
    sleep 0.1
  done
  echo 000
}
pipelined() {
  python3 "$tmp/raw.py" "$port" 'GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n' 'GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n' \
    'POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 2\r\n\r\n{}' \
    'GET /readyz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n'
}
big_head() { python3 "$tmp/raw.py" "$port" "GET /healthz HTTP/1.1\\r\\nHost: x\\r\\n$(printf 'X-Filler: %01000d\\r\\n' $(seq 1 100))\\r\\n"; }
put_no_body() { curl -s -m 5 -o /dev/null -w '%{http_code}\n' -X PUT "$url/v1/jobs"; }
gzip_body() {
  head -c 1M /dev/zero | gzip -c | curl -s -m 10 -o /dev/null -w '%{http_code}\n' -X POST -H 'Content-Type: application/json' \
    -H 'Content-Encoding: gzip' --data-binary @- "$url/v1/jobs"
}
many_ranges() {
  curl -s -m 10 -o /dev/null -w '%{http_code}\n' -H "Range: bytes=0-$(printf ',0-%.0s' $(seq 1 1000))" "$url/ui/app.js"
}

row "10 paths, queries and methods with invalid UTF-8 (%ff)" paths
row "uploads: invalid UTF-8 glTF, a PNG named .gltf, 0xFF in a COLLADA URL, glTF JSON 100,000 deep" uploads
row "job and comparison JSON nested 100,000 deep inside a field" deep
row "endless chunked POST /v1/jobs (1 GiB offered)" chunked /v1/jobs 1
row "four endless chunked POST /v1/jobs at once" chunked /v1/jobs 4
row "endless chunked POST /v1/scenes (1 GiB offered)" chunked "/v1/scenes?name=x.gltf" 1
row "PNG bomb: 1.4 MB glTF declaring 16384x16384 RGBA" bombs 1
row "three PNG bombs at once" bombs 3
row "a 6000x6000 texture (144 MB of texels) uploaded, then a 64x48 job on it" textured_job
row "four requests pipelined on one connection" pipelined
row "100 KB of request headers" big_head
row "PUT /v1/jobs without a body" put_no_body
row "a gzip body (1 KB inflating to 1 MB)" gzip_body
row "a Range of 1,001 parts on a 6 KB file" many_ranges
sleep 54
echo
echo "Idle a minute later: RSS $(mb "$(kib VmRSS)") MB (at start $(mb "$start_rss") MB); /healthz $(alive)."
