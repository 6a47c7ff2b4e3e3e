// A job's status: progress by the one rule (samples over spp × pixels), and a point of the
// convergence curve through the report's JSON and back.
#include "api/job_status.h"

#include <gtest/gtest.h>

#include "api/report.h"

namespace tessera::api {
namespace {

TEST(JobStatus, ProgressIsSamplesOverTheJobsBudget) {
    RenderJob r = default_render_job();
    r.render.width = 10;
    r.render.height = 4;
    r.render.spp = 5;
    const JobProgress p = job_progress(Job{r}, 50, 3, 8);
    EXPECT_DOUBLE_EQ(p.fraction, 0.25);
    EXPECT_EQ(p.tiles_done, 3u);
    EXPECT_EQ(p.tiles_total, 8u);
    EXPECT_EQ(p.samples_done, 50u);
    EXPECT_DOUBLE_EQ(job_progress(Job{r}, 10'000, 8, 8).fraction, 1.0) << "held to 1 (adaptive batches may overshoot)";
    EXPECT_DOUBLE_EQ(job_progress(Job{ComparisonJob{}}, 10, 0, 0).fraction, 0.0) << "a comparison has no sample budget";
}

TEST(JobStatus, AConvergencePointRoundTripsThroughTheReportsForm) {
    ConvergencePoint p;
    p.seconds = 1.25;
    p.spp_mean = 7.5;
    p.est_rel_mse = 0.01;
    EXPECT_FALSE(to_json(p).contains("rel_mse")) << "no reference: no error against it";
    for (const double rel : {-1.0, 0.5}) {  // without a reference, then with one
        p.rel_mse = rel;
        p.mse = rel / 2;
        p.mae = rel / 4;
        const ConvergencePoint q = convergence_point_from_json(to_json(p));
        EXPECT_EQ(q.seconds, p.seconds);
        EXPECT_EQ(q.spp_mean, p.spp_mean);
        EXPECT_EQ(q.est_rel_mse, p.est_rel_mse);
        EXPECT_EQ(q.rel_mse, rel < 0 ? -1.0 : rel) << "unmeasured stays unmeasured";
        EXPECT_EQ(q.mse, rel < 0 ? -1.0 : rel / 2);
        EXPECT_EQ(q.mae, rel < 0 ? -1.0 : rel / 4);
    }
}

}  // namespace
}  // namespace tessera::api
