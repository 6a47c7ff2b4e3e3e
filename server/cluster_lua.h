#pragma once
// The Lua scripts that change a render farm's state in Redis. Each runs atomically, so a node
// that dies between two of them leaves the state of before or after, never between; each checks
// the job's state and pass first, so a task delivered twice (its node went silent, another took
// it over) changes nothing the second time.
#include <string>

namespace tessera::server::lua {

// Moves a job between states, keeping the per-state sets and the queue in step; a final state
// also drops the job's film and delivery counts. Returns 1, or 0 if the job is missing or not
// in one of `allowed` (comma-separated).
inline const std::string transition = R"lua(
local function transition(prefix, id, new_state, allowed, now, err, report)
  local k = prefix .. 'job:' .. id
  local st = redis.call('HGET', k, 'state')
  if not st then return 0 end
  if not string.find(',' .. allowed .. ',', ',' .. st .. ',', 1, true) then return 0 end
  local seq = redis.call('HGET', k, 'seq')
  redis.call('ZREM', prefix .. 'jobs:' .. st, id)
  redis.call('ZADD', prefix .. 'jobs:' .. new_state, seq, id)
  redis.call('HSET', k, 'state', new_state)
  if new_state == 'queued' then
    redis.call('HSET', k, 'started_at', '0')
    local pr = tonumber(redis.call('HGET', k, 'priority'))
    redis.call('ZADD', prefix .. 'queue', string.format('%.0f', (1000 - pr) * 1e12 + tonumber(seq)), id)
  else
    redis.call('ZREM', prefix .. 'queue', id)
  end
  if new_state == 'running' then
    redis.call('HSET', k, 'started_at', now)
    redis.call('HINCRBY', k, 'attempts', 1)
  elseif new_state ~= 'queued' then
    redis.call('HSET', k, 'finished_at', now, 'error', err, 'report', report)
    redis.call('DEL', prefix .. 'film:' .. id, prefix .. 'deliveries:' .. id)
  end
  return 1
end
)lua";

// XADDs the tiles of one pass to a job's task stream.
inline const std::string add_tiles = R"lua(
local function add_tiles(stream, id, pass, n)
  for t = 0, n - 1 do
    redis.call('XADD', stream, '*', 'job', id, 'kind', 'tile', 'pass', pass, 'tile', t)
  end
end
)lua";

}  // namespace tessera::server::lua
