// The wire codec (core/wire.hpp): every width round trips, bytes are little-endian whatever the
// host, and a short read names the field it was reading.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast::wire {
namespace {

TEST(Wire, EveryWidthRoundTrips) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint8_t>(0xfe);
  w.put<int8_t>(-2);
  w.put<uint16_t>(0xfedc);
  w.put<int16_t>(-12345);
  w.put<uint32_t>(0xfedcba98u);
  w.put<int32_t>(std::numeric_limits<int32_t>::min());
  w.put<uint64_t>(0xfedcba9876543210ull);
  w.put<int64_t>(-1234567890123456789ll);
  w.put<float>(-1.5f);
  w.put<double>(3.141592653589793);
  w.put_string("héllo");
  const std::vector<uint8_t> bytes = {1, 2, 3};
  w.put_bytes(bytes);
  const std::array<int16_t, 3> array = {-1, 2, -300};
  w.put_array<int16_t>(array);
  EXPECT_EQ(out.size(), 1u + 1 + 2 + 2 + 4 + 4 + 8 + 8 + 4 + 8 + (2 + 6) + (4 + 3) + 6);

  Reader r(out, "test");
  EXPECT_EQ(r.get<uint8_t>(), 0xfe);
  EXPECT_EQ(r.get<int8_t>(), -2);
  EXPECT_EQ(r.get<uint16_t>(), 0xfedc);
  EXPECT_EQ(r.get<int16_t>(), -12345);
  EXPECT_EQ(r.get<uint32_t>(), 0xfedcba98u);
  EXPECT_EQ(r.get<int32_t>(), std::numeric_limits<int32_t>::min());
  EXPECT_EQ(r.get<uint64_t>(), 0xfedcba9876543210ull);
  EXPECT_EQ(r.get<int64_t>(), -1234567890123456789ll);
  EXPECT_EQ(r.get<float>(), -1.5f);
  EXPECT_EQ(r.get<double>(), 3.141592653589793);
  EXPECT_EQ(r.get_string(), "héllo");
  const auto span = r.get_span();
  EXPECT_EQ(std::vector<uint8_t>(span.begin(), span.end()), bytes);
  for (const int16_t v : array) EXPECT_EQ(r.get<int16_t>(), v);
  EXPECT_EQ(r.remaining(), 0u);
  r.expect_end();
}

TEST(Wire, BytesAreLittleEndian) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint16_t>(0x0102);
  w.put<uint32_t>(0x03040506u);
  w.put<uint64_t>(0x0708090a0b0c0d0eull);
  w.put<float>(1.0f);   // 0x3f800000
  w.put<double>(-2.0);  // 0xc000000000000000
  w.put<int16_t>(-2);   // 0xfffe
  w.put_string("ab");
  const std::array<uint32_t, 2> array = {0x11223344u, 0x55667788u};
  w.put_array<uint32_t>(array);
  const std::vector<uint8_t> expected = {
      0x02, 0x01,                                       // u16
      0x06, 0x05, 0x04, 0x03,                           // u32
      0x0e, 0x0d, 0x0c, 0x0b, 0x0a, 0x09, 0x08, 0x07,   // u64
      0x00, 0x00, 0x80, 0x3f,                           // f32 1.0
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0,   // f64 -2.0
      0xfe, 0xff,                                       // i16 -2
      0x02, 0x00, 'a',  'b',                            // string
      0x44, 0x33, 0x22, 0x11, 0x88, 0x77, 0x66, 0x55};  // u32 array
  EXPECT_EQ(out, expected);

  std::array<uint8_t, 8> at{};
  store<uint32_t>(at.data() + 2, 0xa1b2c3d4u);
  EXPECT_EQ(at, (std::array<uint8_t, 8>{0, 0, 0xd4, 0xc3, 0xb2, 0xa1, 0, 0}));
  EXPECT_EQ(load<uint32_t>(at.data() + 2), 0xa1b2c3d4u);
  EXPECT_EQ(load<uint16_t>(expected.data()), 0x0102);
  EXPECT_EQ(load<uint64_t>(expected.data() + 6), 0x0708090a0b0c0d0eull);
}

TEST(Wire, ATruncatedReadNamesTheField) {
  const std::vector<uint8_t> in = {1, 2, 3};
  Reader r(in, "test message");
  EXPECT_EQ(r.get<uint16_t>("version"), 0x0201);
  try {
    r.get<uint32_t>("body size");
    FAIL() << "read past the input";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed test message: truncated at body size");
  }
  Reader unnamed(in, "test message");
  unnamed.get<uint16_t>();
  try {
    unnamed.get<uint32_t>();
    FAIL() << "read past the input";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed test message: truncated");
  }
  // A string whose length runs past the input, and a byte string's.
  const std::vector<uint8_t> string = {5, 0, 'a', 'b'};
  EXPECT_THROW(Reader(string, "s").get_string("name"), Error);
  try {
    Reader(string, "s").get_string("name");
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed s: truncated at name");
  }
  const std::vector<uint8_t> bytes = {9, 0, 0, 0, 1};
  EXPECT_THROW(Reader(bytes, "b").get_span("depth"), Error);
  Reader trailing(bytes, "b");
  trailing.get<uint32_t>();
  try {
    trailing.expect_end();
    FAIL() << "a trailing byte passed";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed b: trailing bytes");
  }
}

}  // namespace
}  // namespace volcast::wire
