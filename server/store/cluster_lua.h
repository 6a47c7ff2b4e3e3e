#pragma once
// The Lua scripts that change a render farm's state in Redis. Each runs atomically, so a node
// that dies between two of them leaves the state of before or after, never between; each checks
// the job's state and pass first, so a task delivered twice (its node went silent, another took
// it over) changes nothing the second time.
#include <string>

namespace tessera::server::lua {

// Moves a job between states, keeping the per-state sets and the queue in step; a final state
// also drops the job's film and delivery counts (paused and waiting are not final: they keep
// them). Returns 1, or 0 if the job is missing or not
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
  if new_state == 'succeeded' then
    -- Nodes blocklisted for a job that others then finished failed what others could do: counted
    -- against them across jobs (a job that fails everywhere counts against none).
    for _, n in ipairs(redis.call('SMEMBERS', prefix .. 'blocklist:' .. id)) do
      redis.call('HINCRBY', prefix .. 'nodeblocked', n, 1)
    end
  end
  if new_state == 'running' then
    redis.call('HSET', k, 'started_at', now)
    redis.call('HINCRBY', k, 'attempts', 1)
  elseif new_state ~= 'queued' and new_state ~= 'paused' and new_state ~= 'waiting' then
    -- One job fewer in its lane: a lane none uses is removed (prune_lanes).
    local lane = redis.call('HGET', k, 'lane')
    if lane then redis.call('HINCRBY', prefix .. 'lanejobs', lane, -1) end
    redis.call('HSET', k, 'finished_at', now, 'error', err, 'report', report)
    redis.call('DEL', prefix .. 'film:' .. id, prefix .. 'deliveries:' .. id, prefix .. 'sums:' .. id)
  end
  return 1
end
)lua";

// Queues a shot's chunks of frames as tasks, once: a start task delivered again finds the count
// set and adds none. Each carries the job's run (its resumes so far): a task of a run before the
// last resume is dropped. KEYS: the chunk count, the task stream. ARGV: job id, run, then the
// first frame index and frame count of each chunk.
inline const std::string add_chunks = R"lua(
local n = (#ARGV - 2) / 2
if not redis.call('SET', KEYS[1], n, 'NX') then return 0 end
for i = 3, #ARGV, 2 do
  redis.call('XADD', KEYS[2], '*', 'job', ARGV[1], 'kind', 'frames', 'pass', ARGV[i], 'tile', ARGV[i + 1], 'run', ARGV[2])
end
return 1
)lua";

// A chunk of a shot is written: returns {chunks written, chunks in all}, or {-1, -1} for a chunk
// of a run before the job's last resume (whose plan was dropped). KEYS: the written set, the
// chunk count, the job. ARGV: the chunk's first frame index, its run.
inline const std::string chunk_done = R"lua(
if (redis.call('HGET', KEYS[3], 'run') or '0') ~= ARGV[2] then return {-1, -1} end
redis.call('SADD', KEYS[1], ARGV[1])
return {redis.call('SCARD', KEYS[1]), tonumber(redis.call('GET', KEYS[2]) or '-1')}
)lua";

// XADDs the tiles of one pass to a job's task stream.
inline const std::string add_tiles = R"lua(
local function add_tiles(stream, id, pass, n)
  for t = 0, n - 1 do
    redis.call('XADD', stream, '*', 'job', id, 'kind', 'tile', 'pass', pass, 'tile', t)
  end
end
)lua";

// Stores a tile's film (or resolved pixels) for its pass (once: a duplicate returns 0, a task of
// a pass gone by or a job no longer running returns -1), adds its statistics to the job and its
// node's share, queues `assemble` when it was the pass's last tile, and acknowledges and deletes
// the task in every case: the result and the acknowledgement are one step, and one round trip.
// It follows the prologue made from TileCommit's fields (farm_records.h, commit_tile_script),
// which binds them by name in `a` and adds the counters in add_counters.
inline const std::string commit_tile_body = R"lua(
-- KEYS: job, film, node tiles, node seconds, stream, sums
redis.call('XACK', KEYS[5], a.group, a.task)
redis.call('XDEL', KEYS[5], a.task)
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return -1 end
if tonumber(redis.call('HGET', KEYS[1], 'pass')) ~= tonumber(a.pass) then return -1 end
local p = redis.call('HGET', KEYS[2], 'p' .. a.tile)
if p and tonumber(p) >= tonumber(a.pass) then return 0 end
redis.call('HSET', KEYS[2], 't' .. a.tile, a.film, 'p' .. a.tile, a.pass)
if a.sums ~= '' then redis.call('HSET', KEYS[6], 't' .. a.tile, a.sums) end
add_counters(KEYS[1])
if tonumber(a.max_sample) > tonumber(redis.call('HGET', KEYS[1], 'max_sample') or '0') then
  redis.call('HSET', KEYS[1], 'max_sample', a.max_sample)
end
if a.timed_out == '1' then redis.call('HSET', KEYS[1], 'timed_out', 1) end
redis.call('HINCRBY', KEYS[3], a.node, 1)
redis.call('HINCRBYFLOAT', KEYS[4], a.node, a.seconds)
local done = redis.call('HINCRBY', KEYS[1], 'tiles_done', 1)
if done == tonumber(redis.call('HGET', KEYS[1], 'tiles_total')) then
  redis.call('XADD', KEYS[5], '*', 'job', a.job, 'kind', 'assemble', 'pass', a.pass, 'tile', 0)
end
return 1
)lua";

// Starts a render job's run: queued → running, the run's first fields, the first pass's tiles.
inline const std::string begin_run = transition + add_tiles + R"lua(
-- KEYS: job, stream; ARGV: prefix, id, now (s), then the run's first field, value pairs (farm_run_start)
if redis.call('HGET', KEYS[1], 'state') ~= 'queued' then return 0 end
transition(ARGV[1], ARGV[2], 'running', 'queued', ARGV[3], '', '')
local tiles = 0
for i = 4, #ARGV, 2 do
  redis.call('HSET', KEYS[1], ARGV[i], ARGV[i + 1])
  if ARGV[i] == 'tiles_total' then tiles = tonumber(ARGV[i + 1]) end
end
add_tiles(KEYS[2], ARGV[2], 0, tiles)
return 1
)lua";

// Ends a pass that does not stop the render: its point on the curve, the next pass's target
// and tiles (once: a pass gone by returns 0).
inline const std::string advance_pass = add_tiles + R"lua(
-- KEYS: job, curve, stream[, film]; ARGV: id, pass, next target, point, tiles[, field, value, ...]
-- The pairs after `tiles` go into the film's hash with the pass (guided sampling's targets per
-- tile): an assembler that lost the race for this pass writes none.
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return 0 end
if tonumber(redis.call('HGET', KEYS[1], 'pass')) ~= tonumber(ARGV[2]) then return 0 end
for i = 6, #ARGV - 1, 2 do redis.call('HSET', KEYS[4], ARGV[i], ARGV[i + 1]) end
redis.call('RPUSH', KEYS[2], ARGV[4])
local next = tonumber(ARGV[2]) + 1
redis.call('HSET', KEYS[1], 'pass', next, 'target', ARGV[3], 'tiles_done', 0)
add_tiles(KEYS[3], ARGV[1], next, tonumber(ARGV[5]))
return 1
)lua";

// Ends the run's last pass: its point on the curve, then succeeded with the status summary (once).
inline const std::string complete_run = transition + R"lua(
-- KEYS: job, curve; ARGV: prefix, id, pass, point, now, summary
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return 0 end
if tonumber(redis.call('HGET', KEYS[1], 'pass')) ~= tonumber(ARGV[3]) then return 0 end
redis.call('RPUSH', KEYS[2], ARGV[4])
return transition(ARGV[1], ARGV[2], 'succeeded', 'running', ARGV[5], '', ARGV[6])
)lua";

// Moves a job between states (transition, as a script of its own).
inline const std::string transition_job = transition + R"lua(
-- ARGV: prefix, id, new state, allowed old states, time, error, report
return transition(ARGV[1], ARGV[2], ARGV[3], ARGV[4], ARGV[5], ARGV[6], ARGV[7])
)lua";

// Pauses a job: queued or running → paused, keeping its film and run (transition), and when
// (Redis's clock), so that its time limit does not count the pause. Its nodes see the state and
// drop its tasks.
inline const std::string pause_job = transition + R"lua(
-- KEYS: job; ARGV: prefix, id
if transition(ARGV[1], ARGV[2], 'paused', 'queued,running', '0', '', '') == 0 then return 0 end
local t = redis.call('TIME')
redis.call('HSET', KEYS[1], 'paused_ms', tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000))
return 1
)lua";

// Resumes a paused job. One that never began, or runs whole on a node (a comparison, a shot),
// is queued again with a start task (a shot's plan of chunks is dropped: its start plans the
// frames not yet written afresh); a still that began runs again where it stopped: the tiles of its pass not yet stored are queued again (those
// dropped while it was paused; a duplicate of one still queued stores nothing the second time),
// or its assembly when every tile is stored. Its run's clock moves on by the pause.
inline const std::string resume_job = transition + R"lua(
-- KEYS: job, film, task stream, a shot's chunk count, its chunks written; ARGV: prefix, id
local k = KEYS[1]
if redis.call('HGET', k, 'state') ~= 'paused' then return 0 end
local t = redis.call('TIME')
local now_ms = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
local paused_ms = tonumber(redis.call('HGET', k, 'paused_ms') or '')
redis.call('HDEL', k, 'paused_ms')
local total = tonumber(redis.call('HGET', k, 'tiles_total') or '')
if not total then
  -- A new run: tasks of the one paused (still in a node's hands until its next heartbeat, or
  -- queued) carry the old number and are dropped.
  local run = redis.call('HINCRBY', k, 'run', 1)
  redis.call('DEL', KEYS[4], KEYS[5])
  transition(ARGV[1], ARGV[2], 'queued', 'paused', '0', '', '')
  redis.pcall('XGROUP', 'CREATE', KEYS[3], 'nodes', '0', 'MKSTREAM')
  redis.call('XADD', KEYS[3], '*', 'job', ARGV[2], 'kind', 'start', 'pass', '0', 'tile', '0', 'run', run)
  return 1
end
local seq = redis.call('HGET', k, 'seq')
redis.call('ZREM', ARGV[1] .. 'jobs:paused', ARGV[2])
redis.call('ZADD', ARGV[1] .. 'jobs:running', seq, ARGV[2])
redis.call('HSET', k, 'state', 'running')
if paused_ms and redis.call('HEXISTS', k, 'started_ms') == 1 then
  redis.call('HINCRBY', k, 'started_ms', now_ms - paused_ms)
end
local pass = tonumber(redis.call('HGET', k, 'pass'))
local missing = 0
for tile = 0, total - 1 do
  local p = redis.call('HGET', KEYS[2], 'p' .. tile)
  if not p or tonumber(p) < pass then
    redis.call('XADD', KEYS[3], '*', 'job', ARGV[2], 'kind', 'tile', 'pass', pass, 'tile', tile)
    missing = missing + 1
  end
end
if missing == 0 then redis.call('XADD', KEYS[3], '*', 'job', ARGV[2], 'kind', 'assemble', 'pass', pass, 'tile', 0) end
return 1
)lua";

// Releases a waiting job (every job it runs after has succeeded): queued, with its start task.
inline const std::string release_job = transition + R"lua(
-- KEYS: priorities, the lane's task stream; ARGV: prefix, id, priority, lane
if transition(ARGV[1], ARGV[2], 'queued', 'waiting', '0', '', '') == 0 then return 0 end
redis.call('ZADD', KEYS[1], ARGV[3], ARGV[4])
redis.pcall('XGROUP', 'CREATE', KEYS[2], 'nodes', '0', 'MKSTREAM')
redis.call('XADD', KEYS[2], '*', 'job', ARGV[2], 'kind', 'start', 'pass', '0', 'tile', '0')
return 1
)lua";

// A task failed on a node (its error was not the job's: another node may do it). The failure is
// counted for the task and the node, with its reason; a node that failed `blocklist_after` of the
// job's tasks is blocklisted for it. The task is queued again (naming the nodes that failed it,
// so that another takes it where there is one) unless it failed more than `max_retries` times or
// no live node that could take it is left: then the job fails with every reason. Acknowledges
// and deletes the failed delivery in every case. Returns {0 job no longer running, 1 queued
// again, 2 job failed; 1 when this node is now blocklisted for the job}.
inline const std::string fail_task = transition + R"lua(
-- KEYS: job, failures, reasons, blocklist, stream, node failed tasks
-- ARGV: prefix, id, entry, task key, node, reason, max_retries, blocklist_after, now, kind,
--       pass, tile, avoid, what the task is, run, consumer, then every live node whose tags the
--       job's lane needs
-- Only the consumer that holds the delivery settles it: one taken over meanwhile, or settled by
-- an earlier call whose answer was lost, is not counted or queued twice.
if #redis.call('XPENDING', KEYS[5], 'nodes', ARGV[3], ARGV[3], 1, ARGV[16]) == 0 then return {0, 0} end
local st = redis.call('HGET', KEYS[1], 'state')
redis.call('XACK', KEYS[5], 'nodes', ARGV[3])
redis.call('XDEL', KEYS[5], ARGV[3])
if st ~= 'queued' and st ~= 'running' then return {0, 0} end
local node = ARGV[5]
local tries = redis.call('HINCRBY', KEYS[2], 'task:' .. ARGV[4], 1)
local mine = redis.call('HINCRBY', KEYS[2], 'node:' .. node, 1)
redis.call('HINCRBY', KEYS[2], 'total', 1)
redis.call('RPUSH', KEYS[3], ARGV[6])
redis.call('LTRIM', KEYS[3], -50, -1)
redis.call('HINCRBY', KEYS[6], node, 1)
local blocked = 0
if mine >= tonumber(ARGV[8]) then
  blocked = 1
  redis.call('SADD', KEYS[4], node)
end
local why = nil
if tries > tonumber(ARGV[7]) then
  why = ARGV[14] .. ' failed ' .. tries .. " times, more than the job's max_retries (" .. ARGV[7] .. ')'
else
  local left = 0
  for i = 17, #ARGV do
    if redis.call('SISMEMBER', KEYS[4], ARGV[i]) == 0 then left = left + 1 end
  end
  if left == 0 then
    local b = redis.call('SMEMBERS', KEYS[4])
    table.sort(b)
    why = 'no live render node can take its tasks: ' .. table.concat(b, ', ') .. ' failed ' .. ARGV[8] ..
          ' of them each (blocklist_after) and no other node has the tags it requires'
  end
end
if why then
  transition(ARGV[1], ARGV[2], 'failed', 'queued,running', ARGV[9],
             why .. '. Failures: ' .. table.concat(redis.call('LRANGE', KEYS[3], 0, -1), '; '), '')
  return {2, blocked}
end
local avoid = ARGV[13]
if not string.find(',' .. avoid .. ',', ',' .. node .. ',', 1, true) then
  if avoid == '' then avoid = node else avoid = avoid .. ',' .. node end
end
redis.call('XADD', KEYS[5], '*', 'job', ARGV[2], 'kind', ARGV[10], 'pass', ARGV[11], 'tile', ARGV[12],
           'attempt', tries + 1, 'avoid', avoid, 'run', ARGV[15])
return {1, blocked}
)lua";

// A node hands a task to the others (it is blocklisted for the job, or failed this task before
// and another node can take it): the same task queued again, its delivery acknowledged, at once.
inline const std::string pass_on = R"lua(
-- KEYS: stream; ARGV: entry, job, kind, pass, tile, attempt, avoid, run, consumer
if #redis.call('XPENDING', KEYS[1], 'nodes', ARGV[1], ARGV[1], 1, ARGV[9]) == 0 then return 0 end  -- not ours (any more)
redis.call('XADD', KEYS[1], '*', 'job', ARGV[2], 'kind', ARGV[3], 'pass', ARGV[4], 'tile', ARGV[5],
           'attempt', ARGV[6], 'avoid', ARGV[7], 'run', ARGV[8])
redis.call('XACK', KEYS[1], 'nodes', ARGV[1])
redis.call('XDEL', KEYS[1], ARGV[1])
return 1
)lua";

// A job whose every live node that could take its tasks is blocklisted: failed, with every
// reason (a node blocklisted for it holds one of its tasks and finds no other to pass it to).
inline const std::string strand_job = transition + R"lua(
-- KEYS: job, reasons, blocklist; ARGV: prefix, id, now
local b = redis.call('SMEMBERS', KEYS[3])
table.sort(b)
return transition(ARGV[1], ARGV[2], 'failed', 'queued,running', ARGV[3],
                  'no live render node can take its tasks: ' .. table.concat(b, ', ') ..
                  ' are blocklisted for it and no other node has the tags it requires. Failures: ' ..
                  table.concat(redis.call('LRANGE', KEYS[2], 0, -1), '; '), '')
)lua";

// Appends a line to a job's log, keeping the newest `keep`, and counts every line ever
// appended, so that a reader's `from` names the same line after the oldest are dropped.
inline const std::string append_log = R"lua(
-- KEYS: log, count, job; ARGV: line, keep
if redis.call('EXISTS', KEYS[3]) == 0 then return 0 end  -- removed: no log of its own again
redis.call('RPUSH', KEYS[1], ARGV[1])
redis.call('LTRIM', KEYS[1], -tonumber(ARGV[2]), -1)
return redis.call('INCR', KEYS[2])
)lua";

// A job's log from line `from` (counted from the first line ever appended; lines dropped
// since are skipped), at most `limit` lines and about `bytes` bytes (one line at least).
// Returns the number of the first line returned (where the lines dropped put it), then the
// lines. A log without a count (written before it was kept) starts at its first.
inline const std::string read_log = R"lua(
-- KEYS: log, count; ARGV: from, limit, bytes
local len = redis.call('LLEN', KEYS[1])
local count = tonumber(redis.call('GET', KEYS[2]) or tostring(len))
local from = tonumber(ARGV[1])
local start = from - (count - len)
if start < 0 then
  from = from - start
  start = 0
elseif start > len then  -- past the end: the next line is the log's next
  from = count
  start = len
end
local out = {from}
local size = 0
local limit, bytes = tonumber(ARGV[2]), tonumber(ARGV[3])
-- In batches, so that a page of large records is not all copied before the budget cuts it.
while #out - 1 < limit do
  local want = math.min(100, limit - (#out - 1))
  local batch = redis.call('LRANGE', KEYS[1], start, start + want - 1)
  for _, line in ipairs(batch) do
    size = size + #line + 1
    if #out > 1 and size > bytes then return out end
    out[#out + 1] = line
  end
  if #batch < want then break end
  start = start + want
end
return out
)lua";

// Removes the lanes of required tags that no unfinished job uses and whose stream holds nothing
// (a client must not grow the streams nodes read with a new set of tags per job). A job queued
// into a lane removed here makes it again (the insert script). KEYS: the lanes (priorities), the
// jobs per lane. ARGV: prefix. Returns the lanes removed.
inline const std::string prune_lanes = R"lua(
local removed = 0
for _, lane in ipairs(redis.call('ZRANGE', KEYS[1], 0, -1)) do
  if string.find(lane, '|', 1, true) then
    local jobs = tonumber(redis.call('HGET', KEYS[2], lane) or '0')
    local stream = ARGV[1] .. 'tasks:' .. lane
    if jobs <= 0 and redis.call('XLEN', stream) == 0 then
      redis.call('DEL', stream)
      redis.call('ZREM', KEYS[1], lane)
      redis.call('HDEL', KEYS[2], lane)
      removed = removed + 1
    end
  end
end
return removed
)lua";

// Renews a claim only while it is still this consumer's: a node resumed after a long stop must
// not take back a task another node has claimed meanwhile.
inline const std::string renew_claim = R"lua(
-- KEYS: stream; ARGV: id, consumer
local p = redis.call('XPENDING', KEYS[1], 'nodes', ARGV[1], ARGV[1], 1, ARGV[2])
if #p == 0 then return 0 end
redis.call('XCLAIM', KEYS[1], 'nodes', ARGV[2], 0, ARGV[1], 'JUSTID')
return 1
)lua";

}  // namespace tessera::server::lua
