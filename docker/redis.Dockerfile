# Redis 7 from Debian 12's package, configured as a render farm's queue (docs/scaling.md):
# AOF on, fsync every second, reachable on the compose network only.
FROM debian:12
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends redis-server \
 && rm -rf /var/lib/apt/lists/*
USER redis
VOLUME /var/lib/redis
EXPOSE 6379
CMD ["redis-server", "--bind", "0.0.0.0", "--protected-mode", "no", "--dir", "/var/lib/redis", \
     "--appendonly", "yes", "--appendfsync", "everysec", "--save", ""]
