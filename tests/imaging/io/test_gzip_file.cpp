#include "expect_error.hpp"
#include "file_bytes.hpp"
#include "temp_folder.hpp"

#include "imaging/io/gzip_file.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <mutex>
#include <random>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

using tests::file_bytes;
using tests::gunzip;

/// Float noise (as incompressible as a displacement field) with runs of zeros (as an image
/// background).
std::vector<char> test_data(std::size_t bytes) {
  std::vector<char> d(bytes, 0);
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0F, 2.0F);
  for (std::size_t i = 0; i + 4 <= bytes / 2; i += 4) {
    const float v = n(rng);
    std::memcpy(&d[i], &v, 4);
  }
  for (std::size_t i = bytes / 2; i < bytes; ++i) d[i] = char(i % 7 == 0 ? i / 7 : 0);
  return d;
}

TEST(GzipFile, ChunkedStreamIsOneValidGzipMemberForAnyThreadCount) {
  const tests::TempFolder dir;
  for (const std::size_t size : {std::size_t(0), std::size_t(1), std::size_t(5'000'003)}) {
    const std::vector<char> data = test_data(size);
    std::vector<char> first;
    for (const int threads : {1, 2, 3}) {
      for (const bool rle : {true, false}) {
        SCOPED_TRACE("size " + std::to_string(size) + ", threads " + std::to_string(threads) +
                     ", rle " + std::to_string(rle));
        GzipOptions o;
        o.threads = threads;
        o.run_length = rle;
        o.fast = false;  // zlib; ISA-L below
        const auto path = dir / "d.gz";
        gzip_buffer(data.data(), data.size(), path, o);
        // Exact round trip through zlib's reader (checks the combined CRC-32 and length).
        EXPECT_EQ(gunzip(path), data);
        // One member: the gzip magic appears once at the start (the chunks are raw deflate).
        const std::vector<char> bytes = file_bytes(path);
        ASSERT_GE(bytes.size(), 18U);
        EXPECT_EQ(static_cast<unsigned char>(bytes[0]), 0x1f);
        EXPECT_EQ(static_cast<unsigned char>(bytes[1]), 0x8b);
        // The same options give the same bytes (no timing or clock in the file).
        gzip_buffer(data.data(), data.size(), path, o);
        EXPECT_EQ(file_bytes(path), bytes);
        if (size > 4'000'000 && threads == 2 && rle) first = bytes;
      }
    }
    // Compression happens: the zero half of 5 MB shrinks it below 80 % (noise half ≈ 85 %, zeros ≈
    // 0).
    if (!first.empty()) {
      EXPECT_LT(double(first.size()), 0.8 * double(size));
    }
  }
}

TEST(GzipFile, FastDeflateIsAnotherValidStreamOfTheSameBytes) {
  // GzipOptions::fast (ISA-L's igzip, when built with it): each chunk deflated by another
  // deflater, so other compressed bytes, but zlib's reader must give back exactly the input, for
  // any chunking and at each level igzip has; without ISA-L the option changes nothing.
  const tests::TempFolder dir;
  for (const std::size_t size : {std::size_t(1), std::size_t(70'000), std::size_t(5'000'003)}) {
    const std::vector<char> data = test_data(size);
    for (const int threads : {1, 2, 3})
      for (const int level : {1, 2, 3}) {
        SCOPED_TRACE("size " + std::to_string(size) + ", threads " + std::to_string(threads) +
                     ", level " + std::to_string(level));
        GzipOptions fast;
        fast.threads = threads;
        fast.level = level;
        GzipOptions zlib = fast;
        zlib.fast = false;
        gzip_buffer(data.data(), data.size(), dir / "fast.gz", fast);
        gzip_buffer(data.data(), data.size(), dir / "zlib.gz", zlib);
        EXPECT_EQ(gunzip(dir / "fast.gz"), data);
        EXPECT_EQ(gunzip(dir / "zlib.gz"), data);
        // Reproducible: the same data and options give the same bytes again.
        const std::vector<char> first = file_bytes(dir / "fast.gz");
        gzip_buffer(data.data(), data.size(), dir / "fast.gz", fast);
        EXPECT_TRUE(file_bytes(dir / "fast.gz") == first);
        if (size > 4'000'000) {
          // igzip's streams differ from zlib's: the option is in effect when built with it.
          EXPECT_EQ(file_bytes(dir / "fast.gz") != file_bytes(dir / "zlib.gz"),
                    gzip_has_fast_deflate());
          // and it compresses (the zero half): below 80 % as with zlib.
          EXPECT_LT(double(file_bytes(dir / "fast.gz").size()), 0.8 * double(size));
        }
      }
  }
}

TEST(GzipFile, SourceGivesTheBufferStreamBlockByBlock) {
  // gzip_source() deflates blocks made on demand (a writer's reordered volume) instead of one
  // buffer: the file must be gzip_buffer()'s byte for byte, for zlib and igzip, any chunking, with
  // every block asked once, at a multiple of kGzipBlockBytes, no longer than one block.
  const tests::TempFolder dir;
  for (const std::size_t size : {std::size_t(0), std::size_t(1), std::size_t(5'000'003)}) {
    const std::vector<char> data = test_data(size);
    for (const int threads : {1, 2, 3})
      for (const bool fast : {true, false}) {
        SCOPED_TRACE("size " + std::to_string(size) + ", threads " + std::to_string(threads) +
                     ", fast " + std::to_string(fast));
        GzipOptions o;
        o.threads = threads;
        o.fast = fast;
        std::mutex m;
        std::vector<std::size_t> asked;
        bool aligned = true;
        const ByteSource source = [&](std::size_t offset, std::size_t n, unsigned char* out) {
          const std::lock_guard lock(m);
          asked.push_back(offset);
          aligned = aligned && offset % kGzipBlockBytes == 0 && n <= kGzipBlockBytes &&
                    offset + n <= size;
          if (n > 0) std::memcpy(out, data.data() + offset, n);
        };
        gzip_source(size, source, dir / "source.gz", o);
        gzip_buffer(data.data(), data.size(), dir / "buffer.gz", o);
        EXPECT_TRUE(file_bytes(dir / "source.gz") == file_bytes(dir / "buffer.gz"));
        EXPECT_EQ(gunzip(dir / "source.gz"), data);
        EXPECT_TRUE(aligned);
        std::sort(asked.begin(), asked.end());
        EXPECT_TRUE(std::adjacent_find(asked.begin(), asked.end()) == asked.end());
        EXPECT_EQ(asked.size(),
                  std::max<std::size_t>(1, (size + kGzipBlockBytes - 1) / kGzipBlockBytes));
      }
  }
}

TEST(GzipFile, RejectsBadOptionsAndUnreadableSource) {
  const tests::TempFolder dir;
  const char byte = 1;
  GzipOptions o;
  o.level = 10;
  tests::expect_error([&] { gzip_buffer(&byte, 1, dir / "x.gz", o); }, {"x.gz", "level"});
  o = {};
  o.threads = 0;
  tests::expect_error([&] { gzip_buffer(&byte, 1, dir / "x.gz", o); }, {"x.gz", "threads"});
  tests::expect_error([&] { gzip_file(dir / "absent.nii", dir / "x.gz"); },
                      {"absent.nii", "cannot open"});
  tests::expect_error([&] { gzip_buffer(&byte, 1, dir / "no_such_folder" / "x.gz"); },
                      {"x.gz", "cannot open"});
}

TEST(GzipFile, NiftiGzHoldsExactlyTheUncompressedNifti) {
  // A 3-component 96×80×70 float volume (6.5 MB: compressed in two chunks) written as .nii and
  // .nii.gz: the .nii.gz must decompress to the .nii byte for byte, and read back equal.
  const tests::TempFolder dir;
  ImageGeometry g;
  g.size = Eigen::Vector3i(96, 80, 70);
  g.spacing = Vector3d(1.0, 0.9, 1.2);
  g.origin = Vector3d(-40, 30, 5);
  g.direction = Eigen::AngleAxisd(0.3, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  VolumeF v(g, 3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-5.0F, 5.0F);
  for (float& x : v.data) x = u(rng);
  write_volume(dir / "v.nii", v);
  write_volume(dir / "v.nii.gz", v);
  EXPECT_EQ(gunzip(dir / "v.nii.gz"), file_bytes(dir / "v.nii"));
  const VolumeF back = read_volume(dir / "v.nii.gz");
  ASSERT_EQ(back.data.size(), v.data.size());
  EXPECT_EQ(back.data, v.data);  // float storage both ways: exact
  EXPECT_EQ(dir.count(), 2U);    // no temporary (.raw) left behind
}

}  // namespace
}  // namespace brainshift::imaging
