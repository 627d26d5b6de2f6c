// Stream protocol messages: round trips and rejection of malformed or hostile bytes.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "volcast/core/error.hpp"
#include "volcast/net/protocol/frame_set.hpp"

namespace volcast::protocol {
namespace {

TEST(Protocol, HeaderRoundTripsAndRejectsBadFields) {
  uint8_t h[kHeaderBytes];
  write_header(MessageType::kFrameSet, 1234, h);
  const Header parsed = parse_header(h);
  EXPECT_EQ(parsed.type, MessageType::kFrameSet);
  EXPECT_EQ(parsed.payload_bytes, 1234u);

  uint8_t bad[kHeaderBytes];
  std::copy(h, h + kHeaderBytes, bad);
  bad[0] = 'X';
  EXPECT_THROW(parse_header(bad), Error);
  std::copy(h, h + kHeaderBytes, bad);
  bad[4] = 99;  // version 99
  try {
    parse_header(bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("version"), std::string::npos);
  }
  std::copy(h, h + kHeaderBytes, bad);
  bad[6] = 77;  // unknown type
  EXPECT_THROW(parse_header(bad), Error);
  write_header(MessageType::kHello, 0xffffffffu, bad);  // hostile length
  EXPECT_THROW(parse_header(bad), Error);
  write_header(MessageType::kHello, kMaxHelloBytes + 1, bad);
  EXPECT_THROW(parse_header(bad, kMaxHelloBytes), Error);
  EXPECT_THROW(parse_header(std::span(h, 5)), Error);
}

TEST(Protocol, WelcomeCarriesCalibrationExactly) {
  Welcome w;
  CameraInfo cam;
  cam.calibration.depth = {640,  576,   504.6,  504.7, 332.8, 348.8, 0.55, -0.02, -0.003,
                           0.89, 0.086, -0.014, 2e-5,  -7e-5, 0,     0,    1.74};
  cam.calibration.world_from_camera.rotation =
      Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  cam.calibration.world_from_camera.translation = {1.6, -0.2, 0.3};
  cam.description = "Azure Kinect recording";
  w.cameras = {cam, cam};
  w.server_time_us = 1'700'000'000'000'000;
  const Welcome back = parse_welcome(serialize(w));
  EXPECT_EQ(back.server_time_us, w.server_time_us);
  ASSERT_EQ(back.cameras.size(), 2u);
  EXPECT_EQ(back.cameras[1].calibration.depth, cam.calibration.depth);
  EXPECT_EQ(back.cameras[1].calibration.world_from_camera.rotation,
            cam.calibration.world_from_camera.rotation);
  EXPECT_EQ(back.cameras[1].calibration.world_from_camera.translation,
            cam.calibration.world_from_camera.translation);
  EXPECT_EQ(back.cameras[0].description, cam.description);
}

TEST(Protocol, EveryTruncationOfEveryMessageIsRejected) {
  Welcome w;
  w.cameras.resize(1);
  w.cameras[0].calibration.depth = {4, 4, 1, 1, 2, 2};
  std::vector<EncodedCamera> cams(2);
  cams[0].depth = {1, 2, 3};
  cams[0].device_timestamp_us = -5;
  cams[1].color = {4, 5};
  SenderTimes times{123456789, 123456790, 123456795, 0};
  std::vector<uint8_t> body;
  serialize_frame_set_body(42, true, times, cams, body);
  const auto prefix = frame_set_prefix(body.size(), 123456800);
  // The message is the per-viewer prefix followed by the shared body.
  std::vector<uint8_t> frame_msg(prefix.begin(), prefix.end());
  frame_msg.insert(frame_msg.end(), body.begin(), body.end());
  EXPECT_EQ(parse_header(frame_msg).payload_bytes, frame_msg.size() - kHeaderBytes);
  EXPECT_EQ(parse_header(frame_msg).channel, Channel::kFrames);
  const std::vector<uint8_t> frame_payload(frame_msg.begin() + kHeaderBytes, frame_msg.end());
  FrameSetView back;
  parse_frame_set(frame_payload, back);
  EXPECT_EQ(back.sequence, 42u);
  EXPECT_TRUE(back.key);
  EXPECT_EQ(back.times.capture_us, 123456789);
  EXPECT_EQ(back.times.filter_done_us, 123456790);
  EXPECT_EQ(back.times.encode_done_us, 123456795);
  EXPECT_EQ(back.times.send_us, 123456800);
  EXPECT_EQ(back.cameras[0].device_timestamp_us, -5);
  EXPECT_TRUE(std::ranges::equal(back.cameras[0].depth, cams[0].depth));
  EXPECT_TRUE(std::ranges::equal(back.cameras[1].color, cams[1].color));
  EXPECT_TRUE(back.cameras[1].depth.empty());

  Hello sent;
  sent.token[0] = 0xab;
  sent.token[15] = 0xcd;
  sent.tier.depth_codec = "trvl";
  sent.tier.color_codec = "jpeg";
  sent.tier.color_quality = 80;
  const auto hello = serialize(sent);
  EXPECT_EQ(parse_hello(hello).tier.color_quality, 80);
  EXPECT_EQ(parse_hello(hello).token, sent.token);
  // The token is the first 16 bytes, readable without parsing the rest.
  EXPECT_TRUE(std::ranges::equal(hello_token(hello), sent.token));
  EXPECT_THROW(hello_token(std::span(hello).first(15)), Error);
  const auto welcome = serialize(w);
  for (size_t n = 0; n < hello.size(); ++n)
    EXPECT_THROW(parse_hello(std::span(hello).first(n)), Error);
  for (size_t n = 0; n < welcome.size(); ++n)
    EXPECT_THROW(parse_welcome(std::span(welcome).first(n)), Error);
  for (size_t n = 0; n < frame_payload.size(); ++n)
    EXPECT_THROW(parse_frame_set(std::span(frame_payload).first(n), back), Error);
  auto longer = hello;
  longer.push_back(0);
  EXPECT_THROW(parse_hello(longer), Error);  // trailing bytes
}

TEST(Protocol, AdaptationInTheHelloAndTierChangesRoundTripAndRefuseBadFields) {
  Hello sent;
  sent.tier.depth_codec = "volcast";
  sent.tier.color_codec = "jpeg";
  // A pinned viewer's Hello has no tail (as a browser's and older viewers' are).
  const size_t plain = serialize(sent).size();
  sent.adapt = Hello::kAdapt | Hello::kKeepLossless;
  sent.max_bits_per_s = 20'000'000;
  auto hello = serialize(sent);
  EXPECT_EQ(hello.size(), plain + 9);
  EXPECT_EQ(parse_hello(hello).adapt, Hello::kAdapt | Hello::kKeepLossless);
  EXPECT_EQ(parse_hello(hello).max_bits_per_s, 20'000'000u);
  for (size_t n = plain + 1; n < hello.size(); ++n)
    EXPECT_THROW(parse_hello(std::span(hello).first(n)), Error);
  hello[plain] = 0x10;  // a flag this build does not know
  EXPECT_THROW(parse_hello(hello), Error);
  // A browser names the codecs it decodes (its WebAssembly has no video depth).
  sent.decodes = {"volcast", "rvl", "jpeg"};
  const auto browser = serialize(sent);
  EXPECT_EQ(browser.size(), plain + 9 + 1 + (2 + 7) + (2 + 3) + (2 + 4));
  EXPECT_EQ(parse_hello(browser).decodes, sent.decodes);
  for (size_t n = plain + 10; n < browser.size(); ++n)
    EXPECT_THROW(parse_hello(std::span(browser).first(n)), Error);
  auto none = browser;
  none[plain + 9] = 0;  // a list of no codecs
  EXPECT_THROW(parse_hello(none), Error);
  sent.decodes.clear();

  TierChange c{{"h264", "h264", 50, 2}, 18'500, "the path delivers 18.5 Mbit/s"};
  const auto bytes = serialize(c);
  const TierChange back = parse_tier_change(bytes);
  EXPECT_EQ(back.tier.depth_codec, "h264");
  EXPECT_EQ(back.tier.color_quality, 50);
  EXPECT_EQ(back.tier.frame_divisor, 2);
  EXPECT_EQ(back.path_kbit_s, 18'500u);
  EXPECT_EQ(back.reason, c.reason);
  for (size_t n = 0; n < bytes.size(); ++n)
    EXPECT_THROW(parse_tier_change(std::span(bytes).first(n)), Error);
  for (const int divisor : {0, 9}) {
    TierChange bad = c;
    bad.tier.frame_divisor = divisor;
    EXPECT_THROW(parse_tier_change(serialize(bad)), Error) << divisor;
  }
  TierChange loud = c;
  loud.tier.color_quality = 101;
  EXPECT_THROW(parse_tier_change(serialize(loud)), Error);
  auto trailing = bytes;
  trailing.push_back(0);
  EXPECT_THROW(parse_tier_change(trailing), Error);
  // A reason past the limit is cut by the writer, refused by the reader.
  TierChange wordy = c;
  wordy.reason.assign(1000, 'x');
  EXPECT_EQ(parse_tier_change(serialize(wordy)).reason.size(), kMaxReasonBytes);
  uint8_t h[kHeaderBytes];
  write_header(MessageType::kTierChange, 10, h);
  EXPECT_EQ(parse_header(h).type, MessageType::kTierChange);
}

TEST(Protocol, RandomBytesNeverCrashTheParsers) {
  std::mt19937 rng(11);
  FrameSetView out;
  for (int i = 0; i < 2000; ++i) {
    std::vector<uint8_t> bytes(rng() % 200);
    for (auto& b : bytes) b = static_cast<uint8_t>(rng());
    try {
      parse_frame_set(bytes, out);
    } catch (const Error&) {
    }
    try {
      parse_welcome(bytes);
    } catch (const Error&) {
    }
    try {
      parse_hello(bytes);
    } catch (const Error&) {
    }
    try {
      parse_tier_change(bytes);
    } catch (const Error&) {
    }
    try {
      parse_header(bytes);
    } catch (const Error&) {
    }
  }
}

TEST(Protocol, ChannelsSeparateFramesControlAndSessionMessages) {
  uint8_t h[kHeaderBytes];
  write_header(MessageType::kKeyFrameRequest, 0, h);
  EXPECT_EQ(parse_header(h).channel, Channel::kControl);
  EXPECT_EQ(parse_header(h).type, MessageType::kKeyFrameRequest);
  EXPECT_EQ(h[6], 0);  // channel byte
  EXPECT_EQ(h[7], 5);  // type byte
  // A session-channel message of a type this build does not know is accepted (skipped by peers
  // that do not use the session channel); an unknown frames or control type, or channel, is not.
  h[6] = 2;
  h[7] = 42;
  EXPECT_EQ(parse_header(h).channel, Channel::kSession);
  h[6] = 1;
  EXPECT_THROW(parse_header(h), Error);
  h[6] = 0;
  h[7] = 7;
  EXPECT_THROW(parse_header(h), Error);
  h[6] = 3;
  h[7] = 1;
  EXPECT_THROW(parse_header(h), Error);
  // Version 1 peers are told the version does not match.
  write_header(MessageType::kHello, 0, h);
  h[4] = 1;
  try {
    parse_header(h);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("version"), std::string::npos);
  }
  // The allocation-free Ack is the same message as header + serialize_ack.
  const auto ack = ack_message(0x0102030405060708ull);
  EXPECT_TRUE(
      std::ranges::equal(ack, message(MessageType::kAck, serialize_ack(0x0102030405060708ull))));
  // Hello with a quality over 100 is malformed.
  auto hello = serialize(Hello{{}, {"volcast", "jpeg", 100}});
  hello.back() = 101;
  EXPECT_THROW(parse_hello(hello), Error);
}

TEST(Protocol, WelcomeRejectsImplausibleCameras) {
  Welcome w;
  w.cameras.resize(1);
  w.cameras[0].calibration.depth = {4, 4, 0, 1, 2, 2};  // fx = 0
  EXPECT_THROW(parse_welcome(serialize(w)), Error);
  EXPECT_THROW(parse_welcome(serialize(Welcome{})), Error);  // no cameras
}

TEST(Protocol, WelcomeAndFrameSetSizesAreBoundedForTheViewer) {
  CameraInfo cam;
  cam.calibration.depth = {kMaxCameraSide, 1024, 500, 500, 2048, 512};
  Welcome w{{cam}, 0};
  EXPECT_EQ(parse_welcome(serialize(w)).cameras.size(), 1u);
  w.cameras[0].calibration.depth.width = kMaxCameraSide + 1;  // one side too large
  try {
    parse_welcome(serialize(w));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("4097x1024"), std::string::npos) << e.what();
  }
  // Each camera within the side limit, together over the pixel budget.
  cam.calibration.depth.width = cam.calibration.depth.height = 2048;
  w.cameras.assign(kMaxSitePixels / (2048 * 2048), cam);
  EXPECT_NO_THROW(parse_welcome(serialize(w)));
  w.cameras.push_back(cam);
  EXPECT_THROW(parse_welcome(serialize(w)), Error);
  w.cameras.assign(kMaxCameras + 1, CameraInfo{});
  EXPECT_THROW(parse_welcome(serialize(w)), Error);

  // The frame set bound: more than raw depth + raw BGRA per camera, never above the protocol's.
  cam.calibration.depth.width = 640;
  cam.calibration.depth.height = 576;
  const uint32_t two = frame_set_payload_limit(Welcome{{cam, cam}, 0});
  EXPECT_GT(two, 2u * 640 * 576 * 6);
  EXPECT_LT(two, 2u * 640 * 576 * 8 + 2 * kFrameSetCameraOverhead + 1000);
  cam.calibration.depth.width = cam.calibration.depth.height = 4096;
  EXPECT_EQ(frame_set_payload_limit(Welcome{std::vector<CameraInfo>(64, cam), 0}),
            kMaxPayloadBytes);
  // The largest frame set a viewer of this site accepts parses.
  std::vector<EncodedCamera> cams(2);
  for (auto& c : cams) {
    c.depth.resize(640 * 576 * 2);
    c.color.resize(640 * 576 * 4);
  }
  std::vector<uint8_t> body;
  serialize_frame_set_body(1, true, {}, cams, body);
  EXPECT_LE(body.size() + 8, two);
}

}  // namespace
}  // namespace volcast::protocol
