// Hostile HDF5 inputs: single flipped bits (libhdf5 crashes or loops on some),
// a sparse chunked dataset claiming 4 GiB, external links and external storage
// pointing at a FIFO, a FIFO named .h5. Every read ends in success or a clean
// tetlod::Error, quickly, within bounded memory.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>

#include "cli_rusage.hpp"
#include "format_test_util.hpp"
#include "tetlod/converters/hdf5.hpp"

namespace tetlod {
namespace {

using test::slurp;
using test::spit;
using test::tmp_dir;

struct Outcome {
    int ok = 0, errors = 0, crashes = 0, hangs = 0;
};

// Flips one bit of every byte (bit chosen by position) and reads the result.
Outcome flip_every_byte(const std::string& original_path, const std::string& dir) {
    const std::string bytes = slurp(original_path);
    Outcome out;
    VolumeReadOptions opt;
    opt.isolation.timeout_seconds = 3;
    const std::string path = dir + "/flipped.h5";
    // Every byte of the superblock and root group, then a deterministic sample
    // of about 300 more positions (each read forks a process: keep it bounded).
    const std::size_t stride = std::max<std::size_t>(1, bytes.size() / 300);
    for (std::size_t pos = 0; pos < bytes.size(); pos += pos < 256 ? 1 : stride) {
        std::string m = bytes;
        m[pos] = static_cast<char>(m[pos] ^ (1 << (pos * 5 % 8)));
        spit(path, m);
        try {
            read_hdf5(path, "/volume", opt);
            ++out.ok;
        } catch (const Error& e) {
            const std::string w = e.what();
            ++out.errors;
            if (w.find("crashed") != std::string::npos) ++out.crashes;
            if (w.find("did not finish") != std::string::npos) ++out.hangs;
        }
        // Anything but tetlod::Error escapes and fails the test.
    }
    return out;
}

TEST(HostileHdf5, FlippedBitsNeverCrashOrHang) {
    const std::string dir = tmp_dir("h5_flips");
    for (int deflate : {0, 6}) {
        SCOPED_TRACE(deflate);
        const std::string path = dir + "/small.h5";
        Hdf5WriteOptions w;
        w.deflate_level = deflate;
        write_hdf5(test::make_volume(ValueType::I16, {6, 5, 4}), path, "/volume", w);
        const Outcome o = flip_every_byte(path, dir);
        std::printf("deflate %d: bits flipped in a %zu-byte file: %d read, %d refused (%d library crashes, %d hangs caught)\n",
                    deflate, slurp(path).size(), o.ok, o.errors, o.crashes, o.hangs);
        EXPECT_GT(o.errors, 0);  // the test did reach the readers' refusals
    }
}

// A chunked dataset declaring 1024 x 1024 x 4096 bytes (4 GiB) with no chunk
// written: the file is a few KiB, so the claim is refused before allocating.
TEST(HostileHdf5, SparseChunkedClaimOf4GiBIsRefusedInBoundedMemory) {
    const std::string dir = tmp_dir("h5_sparse");
    const std::string path = dir + "/sparse.h5";
    {
        hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        hsize_t shape[3] = {1024, 1024, 4096}, chunk[3] = {64, 64, 64};
        hid_t space = H5Screate_simple(3, shape, nullptr);
        hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
        H5Pset_chunk(dcpl, 3, chunk);
        H5Pset_deflate(dcpl, 6);
        hid_t d = H5Dcreate2(f, "/volume", H5T_STD_U8LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
        ASSERT_GE(d, 0);
        H5Dclose(d);
        H5Pclose(dcpl);
        H5Sclose(space);
        H5Fclose(f);
    }
    try {
        read_hdf5(path, "/volume");
        FAIL() << "4 GiB claim accepted";
    } catch (const Error& e) {
        EXPECT_EQ(e.code(), ErrorCode::TooLarge) << e.what();
        EXPECT_NE(std::string(e.what()).find("stores only 0 bytes"), std::string::npos) << e.what();
    }
    const auto r = test::run_cli({"convert", path + ":/volume", dir + "/out.tlod"}, dir + "/err.txt");
    EXPECT_EQ(r.code, 4) << r.err;
    EXPECT_NE(r.err.find("refused before allocating"), std::string::npos) << r.err;
    EXPECT_LE(r.max_rss_kib, 100 * 1024) << "peak RSS of the refusal";
    EXPECT_FALSE(std::filesystem::exists(dir + "/out.tlod"));
}

Error read_error(const std::string& path, const std::string& dataset) {
    VolumeReadOptions opt;
    opt.isolation.timeout_seconds = 20;
    try {
        read_hdf5(path, dataset, opt);
    } catch (const Error& e) {
        return e;
    }
    ADD_FAILURE() << "read succeeded";
    return Error(ErrorCode::Ok, "");
}

TEST(HostileHdf5, ExternalLinkToAFifoIsNeverOpened) {
    const std::string dir = tmp_dir("h5_elink");
    const std::string fifo = dir + "/target.h5", path = dir + "/links.h5";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    {
        hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        ASSERT_GE(H5Lcreate_external(fifo.c_str(), "/volume", f, "/volume", H5P_DEFAULT, H5P_DEFAULT), 0);
        ASSERT_GE(H5Lcreate_external("target.h5", "/g", f, "/group", H5P_DEFAULT, H5P_DEFAULT), 0);
        H5Fclose(f);
    }
    const auto t0 = std::chrono::steady_clock::now();
    for (const char* ds : {"/volume", "/group/volume", ""}) {
        SCOPED_TRACE(ds);
        const Error e = read_error(path, ds);
        EXPECT_NE(e.code(), ErrorCode::Ok);
        EXPECT_EQ(std::string(e.what()).find("did not finish"), std::string::npos) << e.what();
    }
    EXPECT_EQ(read_error(path, "/volume").code(), ErrorCode::UnsupportedFeature);
    EXPECT_NE(std::string(read_error(path, "/volume").what()).find("external"), std::string::npos);
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 15.0);
    const auto r = test::run_cli({"convert", path + ":/volume", dir + "/out.tlod"}, dir + "/err.txt");
    EXPECT_EQ(r.code, 4) << r.err;
}

// Raw data in external files: a FIFO is refused (IoError), a file outside the
// HDF5 file's folder is not read, a regular sibling file is read.
TEST(HostileHdf5, ExternalStorageIsVetted) {
    const std::string dir = tmp_dir("h5_external");
    auto make = [&](const std::string& h5, const std::string& ext_name) {
        hid_t f = H5Fcreate(h5.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        hsize_t shape[3] = {2, 3, 4};
        hid_t space = H5Screate_simple(3, shape, nullptr);
        hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
        H5Pset_external(dcpl, ext_name.c_str(), 0, 24);
        hid_t d = H5Dcreate2(f, "/volume", H5T_STD_U8LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
        EXPECT_GE(d, 0);
        H5Dclose(d);
        H5Pclose(dcpl);
        H5Sclose(space);
        H5Fclose(f);
    };
    std::string data;
    for (int i = 0; i < 24; ++i) data += static_cast<char>(i * 7);
    spit(dir + "/data.bin", data);
    make(dir + "/good.h5", "data.bin");
    VolumeReadOptions opt;
    const Volume v = read_hdf5(dir + "/good.h5", "/volume", opt);
    ASSERT_EQ(v.count(), 24);
    for (int i = 0; i < 24; ++i) EXPECT_EQ(v.as<uint8_t>()[i], static_cast<uint8_t>(i * 7));

    ASSERT_EQ(::mkfifo((dir + "/pipe.bin").c_str(), 0600), 0);
    make(dir + "/fifo.h5", "pipe.bin");
    const Error e = read_error(dir + "/fifo.h5", "/volume");
    EXPECT_EQ(e.code(), ErrorCode::IoError) << e.what();
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();

    make(dir + "/abs.h5", "/etc/hostname");
    EXPECT_EQ(read_error(dir + "/abs.h5", "/volume").code(), ErrorCode::UnsupportedFeature);
    make(dir + "/up.h5", "../data.bin");
    EXPECT_EQ(read_error(dir + "/up.h5", "/volume").code(), ErrorCode::UnsupportedFeature);
    spit(dir + "/short.bin", "abc");
    make(dir + "/short.h5", "short.bin");
    EXPECT_EQ(read_error(dir + "/short.h5", "/volume").code(), ErrorCode::Truncated);
}

TEST(HostileHdf5, FifoAndNonHdf5AreRefusedBeforeTheLibrary) {
    const std::string dir = tmp_dir("h5_fifo");
    ASSERT_EQ(::mkfifo((dir + "/pipe.h5").c_str(), 0600), 0);
    const Error e = read_error(dir + "/pipe.h5", "/volume");
    EXPECT_EQ(e.code(), ErrorCode::IoError);
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
    spit(dir + "/text.h5", "not an HDF5 file at all, just text that is long enough");
    EXPECT_EQ(read_error(dir + "/text.h5", "/volume").code(), ErrorCode::BadMagic);
    std::string sb = "\x89HDF\r\n\x1a\n";
    sb += std::string("\x09", 1) + std::string(40, '\0');  // superblock version 9
    spit(dir + "/v9.h5", sb);
    EXPECT_EQ(read_error(dir + "/v9.h5", "/volume").code(), ErrorCode::UnsupportedVersion);
}

TEST(HostileHdf5, IsolationCanBeTurnedOff) {
    const std::string dir = tmp_dir("h5_noiso");
    write_hdf5(test::make_volume(ValueType::F32), dir + "/v.h5", "/volume");
    VolumeReadOptions opt;
    opt.isolation.enabled = false;
    const Volume a = read_hdf5(dir + "/v.h5", "/volume", opt);
    const Volume b = read_hdf5(dir + "/v.h5", "/volume");
    EXPECT_EQ(a.data, b.data);
    EXPECT_EQ(a.metadata, b.metadata);
    EXPECT_EQ(a.spacing, b.spacing);
}

}  // namespace
}  // namespace tetlod
