// Must not compile: an engine target sees only engine/ (tests/layering/compile_probe.sh).
#include "api/job.h"
