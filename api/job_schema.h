#pragma once
// The job fields as a JSON Schema (draft-04 vocabulary with OpenAPI's `nullable`), from the
// same tables the parser uses and with this server's limits as maxima: what a client builds a
// form from (GET /v1/job-schema).
#include <nlohmann/json.hpp>

#include "api/job.h"

namespace tessera::api {

// {"render_job": schema, "comparison_job": schema}, properties in the tables' order (a form
// shows them so: scene, width, height, spp, ... rather than alphabetically).
nlohmann::ordered_json job_schema(const JobLimits& limits);

}  // namespace tessera::api
