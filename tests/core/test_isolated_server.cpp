// IsolatedServer and open_planes_isolated: a persistent child answers requests
// in order; every way it can fail during a request (signal, hang, exception,
// exit, memory) becomes a clean tetlod::Error that later calls repeat; the
// child is gone once the server is destroyed; planes read through a child are
// the planes of the volume it opened, in any order.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "tetlod/core/error.hpp"
#include "tetlod/core/isolated_planes.hpp"
#include "tetlod/core/isolated_server.hpp"

namespace tetlod {
namespace {

IsolatedTask task() { return IsolatedTask{"the test library", "input.bin", 10}; }

// A child that sends its pid, then answers each int32 request n with n + 1,
// or misbehaves on the request `bad` in the way `how` says.
IsolatedServer::Serve counter(int bad, const std::function<void()>& how) {
    return [=](IsolatedRequests& rq, IsolatedWriter& w) {
        const int32_t pid = int32_t(::getpid());
        w.write(&pid, sizeof pid);
        int32_t n;
        while (rq.next(&n, sizeof n)) {
            if (n == bad) how();
            const int32_t m = n + 1;
            w.write(&m, sizeof m);
        }
    };
}

int32_t ask(IsolatedServer& s, int32_t n, double seconds = 5) {
    int32_t m = 0;
    s.call(&n, sizeof n, seconds, [&](IsolatedReader& r) { r.read(&m, sizeof m); });
    return m;
}

int32_t pid_of(IsolatedServer& s) {
    int32_t pid = 0;
    s.call(nullptr, 0, 5, [&](IsolatedReader& r) { r.read(&pid, sizeof pid); });
    return pid;
}

Error failure_at(int bad, const std::function<void()>& how, double seconds = 5) {
    IsolatedServer s(task(), counter(bad, how));
    pid_of(s);
    EXPECT_EQ(ask(s, 1), 2);
    EXPECT_EQ(ask(s, 7), 8);
    try {
        ask(s, bad, seconds);
    } catch (const Error& e) {
        // The server is over: the next call repeats the error.
        try {
            ask(s, 1);
            ADD_FAILURE() << "a call after the failure succeeded";
        } catch (const Error& again) {
            EXPECT_EQ(again.code(), e.code());
            EXPECT_STREQ(again.what(), e.what());
        }
        return e;
    }
    ADD_FAILURE() << "no error";
    return Error(ErrorCode::Ok, "");
}

TEST(IsolatedServer, AnswersRequestsInOrderAndIsReapedWhenDestroyed) {
    int32_t pid = 0;
    {
        IsolatedServer s(task(), counter(-1, [] {}));
        pid = pid_of(s);
        EXPECT_NE(pid, ::getpid());
        for (int32_t i = 0; i < 100; ++i) EXPECT_EQ(ask(s, i), i + 1);
    }
    // Killed and reaped: no such process any more (not even a zombie of ours).
    EXPECT_EQ(::kill(pid_t(pid), 0), -1);
    EXPECT_EQ(errno, ESRCH);
}

TEST(IsolatedServer, CrashDuringARequestIsCorruptData) {
    const Error e = failure_at(42, [] { std::raise(SIGSEGV); });
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("the test library crashed (SIGSEGV) reading 'input.bin'"),
              std::string::npos)
        << e.what();
}

TEST(IsolatedServer, HangIsStoppedAtTheRequestsTimeLimit) {
    const Error e = failure_at(
        42,
        [] {
            volatile bool forever = true;
            while (forever) {
            }
        },
        0.5);
    EXPECT_EQ(e.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(e.what()).find("did not finish reading 'input.bin' within 0.5 s"),
              std::string::npos)
        << e.what();
}

TEST(IsolatedServer, ErrorsKeepTheirCodeAndMessage) {
    const Error e =
        failure_at(42, [] { throw Error(ErrorCode::Truncated, "'input.bin' ends early"); });
    EXPECT_EQ(e.code(), ErrorCode::Truncated);
    EXPECT_STREQ(e.what(), "'input.bin' ends early");
    const Error x = failure_at(42, [] { ::_exit(3); });
    EXPECT_EQ(x.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(x.what()).find("exit status 3"), std::string::npos) << x.what();
    const Error z = failure_at(42, [] { ::_exit(0); });  // ends without answering
    EXPECT_EQ(z.code(), ErrorCode::CorruptData);
    EXPECT_NE(std::string(z.what()).find("without a complete result"), std::string::npos)
        << z.what();
}

TEST(IsolatedServer, MemoryLimitEndsAGreedyRequest) {
#ifdef TETLOD_SANITIZED
    GTEST_SKIP() << "no memory limit under AddressSanitizer (its shadow memory counts)";
#endif
    IsolatedTask t = task();
    t.memory_limit_bytes = uint64_t{64} << 20;
    IsolatedServer s(t, counter(42, [] {
                         std::vector<char> big(std::size_t{1} << 30, 1);  // 1 GiB: past the limit
                         if (big[12345] != 1) ::_exit(5);
                     }));
    pid_of(s);
    EXPECT_EQ(ask(s, 3), 4);
    try {
        ask(s, 42);
        ADD_FAILURE() << "the child allocated past its limit";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::TooLarge) << e.what();
        EXPECT_NE(std::string(e.what()).find("ran out of memory reading 'input.bin'"),
                  std::string::npos)
            << e.what();
    }
}

TEST(IsolatedServer, ParentExceptionKillsTheChild) {
    IsolatedServer s(task(), counter(-1, [] {}));
    const int32_t pid = pid_of(s);
    const int32_t n = 5;
    EXPECT_THROW(
        s.call(&n, sizeof n, 5,
               [](IsolatedReader&) { throw Error(ErrorCode::SizeMismatch, "parent says no"); }),
        Error);
    EXPECT_EQ(::kill(pid_t(pid), 0), -1);
    EXPECT_THROW(ask(s, 1), Error);
}

Volume sample(Dims d, ValueType t) {
    Volume v = Volume::allocate(d, t);
    for (int64_t i = 0; i < v.count(); ++i) v.set_value(i, double((i * 7919) % 251));
    v.spacing = {0.5, 2, 3};
    v.field_name = "rho";
    v.metadata["k"] = "v";
    return v;
}

TEST(IsolatedPlanes, PlanesComeBackInAnyOrderAndBadRangesAreRefused) {
    // Planes of 1 MiB: several planes per piece; and planes larger than a piece.
    for (Dims d : {Dims{7, 5, 9}, Dims{1024, 256, 20}, Dims{3000, 3000, 3}}) {
        const Volume v = sample(d, ValueType::U16);
        auto planes = open_planes_isolated(task(), IsolationOptions{}, [&] {
            return PlanesInChild{planes_of(v), 0};
        });
        EXPECT_EQ(planes->header().dims, v.dims);
        EXPECT_EQ(planes->header().spacing, v.spacing);
        EXPECT_EQ(planes->header().metadata, v.metadata);
        const std::size_t plane = std::size_t(d.x * d.y) * 2;
        std::vector<int64_t> order(std::size_t(d.z));
        std::iota(order.begin(), order.end(), 0);
        std::shuffle(order.begin(), order.end(), std::mt19937(3));
        std::vector<std::byte> got(v.data.size());
        for (int64_t z : order) planes->read(z, 1, got.data() + std::size_t(z) * plane);
        EXPECT_TRUE(std::equal(got.begin(), got.end(), v.data.begin()));
        std::fill(got.begin(), got.end(), std::byte{0});
        planes->read(0, d.z, got.data());
        EXPECT_TRUE(std::equal(got.begin(), got.end(), v.data.begin()));
        EXPECT_THROW(planes->read(d.z - 1, 2, got.data()), Error);
        EXPECT_THROW(planes->read(-1, 1, got.data()), Error);
        planes->read(d.z - 1, 1, got.data());  // still serving
        EXPECT_TRUE(std::equal(got.begin(), got.begin() + std::ptrdiff_t(plane),
                               v.data.begin() + std::ptrdiff_t((d.z - 1) * int64_t(plane))));
    }
}

TEST(IsolatedPlanes, AChildThatFailsToOpenOrCrashesReadingIsAnError) {
    try {
        open_planes_isolated(task(), IsolationOptions{}, []() -> PlanesInChild {
            throw Error(ErrorCode::NotFound, "'input.bin' has no dataset '/x'");
        });
        ADD_FAILURE() << "opened";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::NotFound);
    }
    // Reading plane 3 crashes the library.
    struct Crashing final : VolumePlanes {
        Volume h = sample({4, 4, 6}, ValueType::U8);
        const Volume& header() const override { return h; }
        void read(int64_t z0, int64_t count, std::byte* dst) override {
            if (z0 <= 3 && 3 < z0 + count) std::raise(SIGSEGV);
            std::memcpy(dst, h.data.data() + z0 * 16, std::size_t(count) * 16);
        }
    };
    auto planes = open_planes_isolated(task(), IsolationOptions{}, [] {
        return PlanesInChild{std::make_unique<Crashing>(), 0};
    });
    std::vector<std::byte> buf(16 * 6);
    planes->read(0, 3, buf.data());
    try {
        planes->read(2, 2, buf.data());
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::CorruptData);
        EXPECT_NE(std::string(e.what()).find("crashed (SIGSEGV) reading 'input.bin'"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_THROW(planes->read(0, 1, buf.data()), Error);
}

}  // namespace
}  // namespace tetlod
