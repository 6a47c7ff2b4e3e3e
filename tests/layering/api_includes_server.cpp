// Must not compile: an api target sees only engine/ and api/ (tests/layering/compile_probe.sh).
#include "server/job_store.h"
