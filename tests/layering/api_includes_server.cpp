// Must not compile: an api target sees only engine/ and api/ (tests/layering/compile_probe.sh).
#include "server/store/job_store.h"
