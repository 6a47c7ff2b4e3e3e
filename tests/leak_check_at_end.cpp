// Under LeakSanitizer, the leak check runs once the last test is over, before the process's
// static destructors. At exit, the libraries' thread pools (OpenEXR's two, and the four of
// log4cplus, which OpenImageIO's dependencies load) end while LSan's tracer suspends every thread
// and reads its stack: now and then a stack goes away under the tracer, which dies of SIGSEGV
// ("Tracer caught signal 11") after every test has passed. Here those threads wait, idle, and the check
// is the same one: what a live object still reaches is not a leak either way.
#include <gtest/gtest.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TESSERA_LEAK_CHECK 1
#endif
#endif
#if !defined(TESSERA_LEAK_CHECK) && defined(__SANITIZE_ADDRESS__)
#define TESSERA_LEAK_CHECK 1
#endif

#ifdef TESSERA_LEAK_CHECK
#include <sanitizer/lsan_interface.h>

namespace {

class LeakCheckAtEnd : public ::testing::Environment {
public:
    // A leak found here ends the process with LSan's report and its exit code, as at exit.
    void TearDown() override { __lsan_do_leak_check(); }
};

[[maybe_unused]] ::testing::Environment* const kLeakCheckAtEnd = ::testing::AddGlobalTestEnvironment(new LeakCheckAtEnd);

}  // namespace
#endif
