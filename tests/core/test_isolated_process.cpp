// run_isolated turns every way a child can fail (signal, hang, exception, early
// exit) into a clean tetlod::Error, and passes results and errors through intact.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <csignal>
#include <filesystem>
#include <new>

#include "tetlod/core/error.hpp"
#include <vector>

#include "tetlod/core/isolated_process.hpp"
#include "tetlod/core/isolated_volume.hpp"
#include "tetlod/core/regular_file.hpp"

namespace tetlod {
namespace {

IsolatedTask task(double seconds = 10) { return IsolatedTask{"the test library", "input.bin", seconds}; }

// Runs `child` isolated with a parent that expects 4 bytes; returns the Error.
Error failure_of(const std::function<void(IsolatedWriter&)>& child, double seconds = 10) {
    try {
        run_isolated(task(seconds), child, [](IsolatedReader& r) {
            char b[4];
            r.read(b, 4);
        });
    } catch (const Error& e) {
        return e;
    }
    ADD_FAILURE() << "no error";
    return Error(ErrorCode::Ok, "");
}

TEST(Isolation, ResultComesBack) {
    std::string got(5, '\0');
    run_isolated(task(), [](IsolatedWriter& w) { w.write("hello", 5); },
                 [&](IsolatedReader& r) { r.read(got.data(), 5); });
    EXPECT_EQ(got, "hello");
}

TEST(Isolation, MemoryLimitEndsAGreedyChild) {
#ifdef TETLOD_SANITIZED
    GTEST_SKIP() << "no memory limit under AddressSanitizer (its shadow memory counts)";
#endif
    IsolatedTask t = task();
    t.memory_limit_bytes = uint64_t{64} << 20;
    try {
        run_isolated(
            t,
            [](IsolatedWriter& w) {
                std::vector<char> big(std::size_t{1} << 30, 1);  // 1 GiB: past the limit
                w.write(big.data(), 4);
            },
            [](IsolatedReader& r) {
                char b[4];
                r.read(b, 4);
            });
        ADD_FAILURE() << "the child allocated past its limit";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::TooLarge) << e.what();
        EXPECT_NE(std::string(e.what()).find("ran out of memory"), std::string::npos) << e.what();
    }
    // The same child with room succeeds; the automatic limit grows with the input.
    t.memory_limit_bytes = 0;
    std::string got(2, '\0');
    run_isolated(t, [](IsolatedWriter& w) { w.write("ok", 2); }, [&](IsolatedReader& r) { r.read(got.data(), 2); });
    EXPECT_EQ(got, "ok");
    IsolationOptions o;
    EXPECT_EQ(isolation_memory_limit(o, 0), uint64_t{96} << 20);
    EXPECT_GT(isolation_memory_limit(o, uint64_t{1} << 20), uint64_t{12} << 30);  // 1 MiB file: > 12 GiB
    o.memory_limit_bytes = 1234;
    EXPECT_EQ(isolation_memory_limit(o, 1 << 20), 1234u);
}

TEST(Isolation, CrashBecomesCorruptData) {
    const Error e = failure_of([](IsolatedWriter&) { std::raise(SIGSEGV); });
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("the test library crashed (SIGSEGV) reading 'input.bin'"), std::string::npos)
        << e.what();
    const Error a = failure_of([](IsolatedWriter&) { std::abort(); });
    EXPECT_NE(std::string(a.what()).find("crashed (SIGABRT)"), std::string::npos) << a.what();
}

TEST(Isolation, CrashAfterPartialResultBecomesCorruptData) {
    const Error e = failure_of([](IsolatedWriter& w) {
        w.write("ab", 2);
        std::raise(SIGSEGV);
    });
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("SIGSEGV"), std::string::npos) << e.what();
}

TEST(Isolation, EndlessLoopIsStoppedAtTheTimeLimit) {
    const Error e = failure_of(
        [](IsolatedWriter&) {
            volatile bool forever = true;
            while (forever) {
            }
        },
        0.5);
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("did not finish reading 'input.bin' within 0.5 s"), std::string::npos)
        << e.what();
}

TEST(Isolation, ErrorsKeepTheirCodeAndMessage) {
    const Error e = failure_of([](IsolatedWriter&) { throw Error(ErrorCode::NotFound, "no dataset '/x' in it"); });
    EXPECT_EQ(e.code(), ErrorCode::NotFound);
    EXPECT_STREQ(e.what(), "no dataset '/x' in it");
    const Error m = failure_of([](IsolatedWriter&) { throw std::bad_alloc(); });
    EXPECT_EQ(m.code(), ErrorCode::TooLarge);
    const Error r = failure_of([](IsolatedWriter&) { throw std::runtime_error("bad node"); });
    EXPECT_EQ(r.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(r.what()).find("bad node"), std::string::npos);
}

TEST(Isolation, ExitWithoutResultIsAnError) {
    const Error e = failure_of([](IsolatedWriter&) { ::_exit(3); });
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("exit status 3"), std::string::npos) << e.what();
    const Error z = failure_of([](IsolatedWriter&) {});  // exits 0 without sending anything
    EXPECT_EQ(z.code(), ErrorCode::CorruptData);
}

TEST(Isolation, ParentExceptionKillsTheChild) {
    EXPECT_THROW(run_isolated(
                     task(), [](IsolatedWriter&) { ::sleep(60); },
                     [](IsolatedReader&) { throw Error(ErrorCode::SizeMismatch, "parent says no"); }),
                 Error);
}

TEST(Isolation, VolumeTravelsWhole) {
    Volume v = Volume::allocate({7, 5, 3}, ValueType::I16);
    for (int64_t i = 0; i < v.count(); ++i) v.set_value(i, static_cast<double>(i * 3 - 50));
    v.spacing = {0.5, 2, 3};
    v.origin = {-1, 4, 9.5};
    v.field_name = "rho";
    v.units = "kg";
    v.metadata["a"] = std::string("x\0y", 3);
    const Volume got = read_volume_isolated(task(), [&] { return v; });
    EXPECT_EQ(got.dims, v.dims);
    EXPECT_EQ(got.type, v.type);
    EXPECT_EQ(got.data, v.data);
    EXPECT_EQ(got.spacing, v.spacing);
    EXPECT_EQ(got.origin, v.origin);
    EXPECT_EQ(got.field_name, "rho");
    EXPECT_EQ(got.units, "kg");
    EXPECT_EQ(got.metadata, v.metadata);
}

TEST(Isolation, VolumeErrorsComeBack) {
    try {
        read_volume_isolated(task(), []() -> Volume { throw Error(ErrorCode::TooLarge, "claims 4 GiB"); });
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::TooLarge);
        EXPECT_STREQ(e.what(), "claims 4 GiB");
    }
}

// A parent that already runs TBB worker threads: the child has only the forking
// thread, and TBB work in it must still complete (not deadlock on workers that
// do not exist there).
TEST(Isolation, ChildCanUseTbbAfterTheParentStartedWorkers) {
    std::atomic<long> sum{0};
    tbb::parallel_for(0, 100000, [&](int i) { sum += i; });
    ASSERT_EQ(sum.load(), 4999950000L);
    const Volume got = read_volume_isolated(task(20), [] {
        Volume v = Volume::allocate({64, 64, 16}, ValueType::U8);
        tbb::parallel_for(int64_t{0}, v.count(), [&](int64_t i) { v.as<uint8_t>()[i] = static_cast<uint8_t>(i); });
        return v;
    });
    for (int64_t i = 0; i < got.count(); ++i) ASSERT_EQ(got.as<uint8_t>()[i], static_cast<uint8_t>(i));
}

TEST(Isolation, TimeLimitGrowsWithTheInput) {
#ifdef TETLOD_SANITIZED
    const double scale = 5;  // sanitizer builds allow their slower readers 5x the default
#else
    const double scale = 1;
#endif
    IsolationOptions o;
    EXPECT_DOUBLE_EQ(isolation_time_limit(o, 0), 10 * scale);
    EXPECT_DOUBLE_EQ(isolation_time_limit(o, 100 << 20), 210 * scale);
    o.timeout_seconds = 3;  // an explicit limit is never scaled
    EXPECT_DOUBLE_EQ(isolation_time_limit(o, 100 << 20), 3);
}

TEST(RegularFile, SpecialFilesAreRefusedWithTheirKind) {
    const std::string dir = std::string(TETLOD_TEST_TMP) + "/regular";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string fifo = dir + "/pipe.nrrd", file = dir + "/plain.raw";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    { std::ofstream(file) << "x"; }
    EXPECT_NO_THROW(require_regular_file(file, "raw volume"));
    EXPECT_NO_THROW(require_regular_file("-", "raw volume"));  // stdin: the caller's business
    auto code_and_text = [](const std::string& p) -> std::pair<ErrorCode, std::string> {
        try {
            require_regular_file(p, "NRRD header");
        } catch (const Error& e) {
            return {e.code(), e.what()};
        }
        return {ErrorCode::Ok, ""};
    };
    auto [c1, t1] = code_and_text(fifo);
    EXPECT_EQ(c1, ErrorCode::IoError);
    EXPECT_NE(t1.find("FIFO"), std::string::npos) << t1;
    auto [c2, t2] = code_and_text(dir);
    EXPECT_EQ(c2, ErrorCode::IoError);
    EXPECT_NE(t2.find("directory"), std::string::npos) << t2;
    auto [c3, t3] = code_and_text("/dev/zero");
    EXPECT_EQ(c3, ErrorCode::IoError);
    EXPECT_NE(t3.find("character device"), std::string::npos) << t3;
    auto [c4, t4] = code_and_text(dir + "/absent");
    EXPECT_EQ(c4, ErrorCode::IoError);
    EXPECT_NE(t4.find("no such file"), std::string::npos) << t4;
    EXPECT_TRUE(regular_file_failure(fifo).has_value());
    EXPECT_FALSE(regular_file_failure(file).has_value());
}

}  // namespace
}  // namespace tetlod
