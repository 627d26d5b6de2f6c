// Site configs as `volcast calibrate` writes them (full intrinsics, registration) and camera
// folders (depth.<serial>-<n>.png side by side) as sources; `volcast serve --config` end to end.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/capture/camera_folder.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/io/site_config.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

const std::string kVolcast = test::paths::volcast();

// The Azure Kinect recording's factory NFOV depth intrinsics (full Brown-Conrady model): what the
// four-camera set is used with.
Intrinsics kinect() {
  return open_source(test::kinect_mkv())->calibration().depth;
}

fs::path four_cameras() {
  return fs::path(test::paths::data()) / "k4a-4cam-nfov";
}

void write_text(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
}

nlohmann::json read_json(const fs::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(SiteConfig, WrittenConfigReadsBackExactly) {
  const fs::path file = test::temp_dir("site_config_round_trip") / "site.json";
  SiteCamera a;
  a.source = "cams/depth.A-0001.png";
  a.name = "A";
  a.intrinsics = kinect();
  ASSERT_FALSE(a.intrinsics->is_pinhole());
  a.world_from_camera = RigidTransform{rotation_from_degrees({10, -20, 30}), {1, 2, -3}};
  a.registration = SiteRegistration{"target", 0.8, 7.5};
  a.filters_json = R"({"near_mm":300})";
  SiteCamera b;  // the least an entry can hold, and a pinhole without a size
  b.source = "/data/recording.mkv";
  b.intrinsics = Intrinsics{};
  b.intrinsics->fx = 460.5, b.intrinsics->fy = 461, b.intrinsics->cx = 320, b.intrinsics->cy = 180;
  SiteCamera c;
  c.source = "seq";
  c.registration = SiteRegistration{"targetless", -1, 4.25};
  write_site_config(file, std::vector<SiteCamera>{a, b, c});

  const auto back = read_site_config(file);
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back[0].source, a.source);
  EXPECT_EQ(back[0].name, "A");
  ASSERT_TRUE(back[0].intrinsics);
  EXPECT_EQ(*back[0].intrinsics, *a.intrinsics);  // every lens term, bit for bit
  ASSERT_TRUE(back[0].world_from_camera);
  EXPECT_TRUE(back[0].world_from_camera->rotation.isApprox(a.world_from_camera->rotation, 1e-12));
  EXPECT_TRUE(
      back[0].world_from_camera->translation.isApprox(a.world_from_camera->translation, 1e-12));
  ASSERT_TRUE(back[0].registration);
  EXPECT_EQ(back[0].registration->method, "target");
  EXPECT_EQ(back[0].registration->feature_rms_mm, 0.8);
  EXPECT_EQ(back[0].registration->overlap_rms_mm, 7.5);
  EXPECT_EQ(nlohmann::json::parse(back[0].filters_json), nlohmann::json::parse(a.filters_json));
  EXPECT_EQ(back[1].name, "");
  EXPECT_EQ(*back[1].intrinsics, *b.intrinsics);
  EXPECT_FALSE(back[1].world_from_camera);
  EXPECT_FALSE(back[1].registration);
  EXPECT_EQ(back[1].filters_json, "");
  EXPECT_FALSE(back[2].intrinsics);
  EXPECT_EQ(back[2].registration->feature_rms_mm, -1);  // not measured: not written
  EXPECT_EQ(back[2].registration->overlap_rms_mm, 4.25);

  // The file as documented: full lens keys, size only when known, residuals only when measured.
  const auto j = read_json(file);
  EXPECT_EQ(j["cameras"][0]["intrinsics"]["width"], 640);
  EXPECT_EQ(j["cameras"][0]["intrinsics"]["metric_radius"], a.intrinsics->metric_radius);
  EXPECT_EQ(j["cameras"][0]["filters"]["near_mm"], 300);
  EXPECT_FALSE(j["cameras"][1]["intrinsics"].contains("width"));
  EXPECT_EQ(j["cameras"][1]["intrinsics"]["k1"], 0.0);
  EXPECT_FALSE(j["cameras"][2]["registration"].contains("feature_rms_mm"));
  // read_site_poses agrees.
  const auto poses = read_site_poses(file);
  ASSERT_EQ(poses.size(), 3u);
  ASSERT_TRUE(poses[0]);
  EXPECT_TRUE(poses[0]->translation.isApprox(Eigen::Vector3d(1, 2, -3)));
  EXPECT_FALSE(poses[1]);
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
}

TEST(SiteConfig, TheViewersSaveKeepsIntrinsicsAndRegistration) {
  const fs::path file = test::temp_dir("site_config_save") / "site.json";
  SiteCamera a;
  a.source = "a.mkv";
  a.name = "left";
  a.intrinsics = kinect();
  a.registration = SiteRegistration{"target", 0.5, 3};
  a.filters_json = R"({"far_mm":4000})";
  write_site_config(file, std::vector<SiteCamera>{a});
  const RigidTransform moved{rotation_from_degrees({0, 90, 0}), {0.5, 1.5, 2}};
  write_site_poses(file, std::vector<RigidTransform>{moved});
  const auto back = read_site_config(file);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].name, "left");
  EXPECT_EQ(*back[0].intrinsics, *a.intrinsics);
  EXPECT_EQ(back[0].registration->method, "target");
  EXPECT_EQ(back[0].registration->overlap_rms_mm, 3);
  EXPECT_EQ(nlohmann::json::parse(back[0].filters_json)["far_mm"], 4000);
  ASSERT_TRUE(back[0].world_from_camera);
  EXPECT_TRUE(back[0].world_from_camera->translation.isApprox(moved.translation));
  EXPECT_TRUE(back[0].world_from_camera->rotation.isApprox(moved.rotation, 1e-9));
}

TEST(SiteConfig, PinholeStringAndHandWrittenObjectsStillRead) {
  const fs::path file = test::temp_dir("site_config_pinhole") / "site.json";
  write_text(file, R"({"comment": "by hand", "cameras": [
    {"source": "a", "intrinsics": "460,460.5,320,180", "extra": true},
    {"source": "b", "intrinsics": {"fx": 500, "fy": 501, "cx": 319.5, "cy": 287.5, "k1": 0.25}},
    {"source": "c", "registration": {"method": "start + ICP", "note": "ignored"}}]})");
  const auto cams = read_site_config(file);
  ASSERT_EQ(cams.size(), 3u);
  ASSERT_TRUE(cams[0].intrinsics);
  EXPECT_EQ(cams[0].intrinsics->fx, 460);
  EXPECT_EQ(cams[0].intrinsics->fy, 460.5);
  EXPECT_EQ(cams[0].intrinsics->cx, 320);
  EXPECT_EQ(cams[0].intrinsics->cy, 180);
  EXPECT_EQ(cams[0].intrinsics->width, 0);
  EXPECT_TRUE(cams[0].intrinsics->is_pinhole());
  EXPECT_EQ(cams[1].intrinsics->k1, 0.25);
  EXPECT_EQ(cams[1].intrinsics->k2, 0);  // missing lens keys are 0
  EXPECT_EQ(cams[1].intrinsics->metric_radius, 0);
  EXPECT_EQ(cams[2].registration->method, "start + ICP");
  EXPECT_EQ(cams[2].registration->feature_rms_mm, -1);
}

TEST(SiteConfig, BadEntriesNameTheFileCameraAndKey) {
  const fs::path dir = test::temp_dir("site_config_bad");
  const fs::path file = dir / "site.json";
  // Camera 1 is the bad one: the message names the file, "camera 1" and the key.
  const auto error = [&](const std::string& second) {
    write_text(file, R"({"cameras": [{"source": "ok", "intrinsics": "1,1,0,0"}, )" + second + "]}");
    const std::string e = test::error_of([&] { read_site_config(file); });
    EXPECT_TRUE(contains(e, file.string())) << e;
    EXPECT_TRUE(contains(e, "camera 1")) << e;
    return e;
  };
  const std::string pinhole = R"("fx": 500, "fy": 500, "cx": 320, "cy": 288)";
  EXPECT_TRUE(
      contains(error(R"({"source": "b", "intrinsics": {"fx": -5, "fy": 500, "cx": 1, "cy": 1}})"),
               "\"intrinsics\".\"fx\" must be positive"));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": {)" + pinhole + R"(, "k9": 0}})"),
                       "unknown key \"intrinsics\".\"k9\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": {)" + pinhole + R"(, "k1": "NaN"}})"),
                       "\"intrinsics\".\"k1\" must be a finite number"));
  EXPECT_TRUE(contains(
      error(R"({"source": "b", "intrinsics": {"fx": "500", "fy": 500, "cx": 1, "cy": 1}})"),
      "\"intrinsics\".\"fx\" must be a finite number"));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": {)" + pinhole + R"(, "width": 0}})"),
                       "\"intrinsics\".\"width\" must be an integer 1..8192"));
  EXPECT_TRUE(
      contains(error(R"({"source": "b", "intrinsics": {)" + pinhole + R"(, "height": 9000}})"),
               "\"intrinsics\".\"height\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": {"fx": 500, "fy": 500, "cx": 1}})"),
                       "\"intrinsics\" needs \"cy\""));
  EXPECT_TRUE(
      contains(error(R"({"source": "b", "intrinsics": "nan,500,320,288"})"), "\"fx,fy,cx,cy\""));
  EXPECT_TRUE(
      contains(error(R"({"source": "b", "intrinsics": "500,500,320"})"), "\"fx,fy,cx,cy\""));
  EXPECT_TRUE(
      contains(error(R"({"source": "b", "intrinsics": "500,500,320,288,1"})"), "\"fx,fy,cx,cy\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": "0,500,320,288"})"), "positive"));
  EXPECT_TRUE(contains(error(R"({"source": "b", "intrinsics": [500, 500, 320, 288]})"),
                       "\"intrinsics\" must be"));
  EXPECT_TRUE(contains(error(R"({"name": "no source"})"), "needs \"source\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "name": ""})"), "\"name\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "registration": {"feature_rms_mm": "low"}})"),
                       "\"registration\".\"feature_rms_mm\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "registration": {"method": 3}})"),
                       "\"registration\".\"method\""));
  EXPECT_TRUE(contains(error(R"({"source": "b", "world_from_camera": {"translation": [0, 0, 0]}})"),
                       "\"world_from_camera\".\"translation\""));
  // The file itself.
  write_text(file, R"({"cameras": {}})");
  EXPECT_TRUE(contains(test::error_of([&] { read_site_config(file); }), "\"cameras\" list"));
  EXPECT_TRUE(
      contains(test::error_of([&] { read_site_config(dir / "missing.json"); }), "missing.json"));
  SiteCamera bad_filters;
  bad_filters.source = "x";
  bad_filters.filters_json = "[1";
  EXPECT_TRUE(contains(test::error_of([&] {
                         write_site_config(dir / "out.json", std::vector<SiteCamera>{bad_filters});
                       }),
                       "camera 0"));
  // What would not read back is not written.
  SiteCamera bad_fx;
  bad_fx.source = "x";
  bad_fx.intrinsics = Intrinsics{};
  bad_fx.intrinsics->fx = -1;
  const std::string e = test::error_of([&] {
    write_site_config(dir / "out.json", std::vector<SiteCamera>{bad_filters, bad_fx});
  });
  EXPECT_TRUE(contains(e, "camera 0")) << e;  // the first bad one
  bad_filters.filters_json = "";
  const std::string fx = test::error_of([&] {
    write_site_config(dir / "out.json", std::vector<SiteCamera>{bad_filters, bad_fx});
  });
  EXPECT_TRUE(contains(fx, "camera 1: \"intrinsics\".\"fx\" must be positive")) << fx;
  EXPECT_FALSE(fs::exists(dir / "out.json"));
}

TEST(SiteConfig, RelativeSourcesResolveAgainstTheConfigFolder) {
  const fs::path dir = test::temp_dir("site_config_resolve");
  const fs::path config = dir / "site.json";
  EXPECT_EQ(resolve_site_source("cams/depth.A-0001.png", config),
            dir / "cams" / "depth.A-0001.png");  // not in the working directory
  EXPECT_EQ(resolve_site_source("/abs/x.mkv", config), fs::path("/abs/x.mkv"));
  EXPECT_EQ(resolve_site_source(dir.string(), config), dir);
  const fs::path cwd = fs::current_path();
  fs::current_path(dir);
  fs::create_directories(dir / "here");
  EXPECT_EQ(resolve_site_source("here", dir / "elsewhere" / "site.json"), fs::path("here"));
  fs::current_path(cwd);
}

TEST(CameraFolder, TheFourKinectsAreFourCameras) {
  const auto cameras = list_folder_cameras(four_cameras());
  ASSERT_EQ(cameras.size(), 4u);
  const std::vector<std::string> serials = {"000123102712", "000174202712", "000241702712",
                                            "000330102712"};
  for (size_t i = 0; i < cameras.size(); ++i) {
    EXPECT_EQ(cameras[i].serial, serials[i]);
    ASSERT_EQ(cameras[i].depth.size(), 1u);
    ASSERT_EQ(cameras[i].color.size(), 1u);
    EXPECT_EQ(cameras[i].depth[0].filename(), "depth." + serials[i] + "-0001.png");
    EXPECT_EQ(cameras[i].color[0].filename(), "rgb." + serials[i] + "-0001.png");
  }
  // The folder is not one source; nor is a PNG without intrinsics.
  const std::string folder = test::error_of([&] { open_source(four_cameras()); });
  EXPECT_TRUE(contains(folder, "4 cameras")) << folder;
  EXPECT_TRUE(contains(folder, "depth.<serial>-*.png per camera")) << folder;
  const std::string no_intrinsics = test::error_of([&] { open_source(cameras[0].depth[0]); });
  EXPECT_TRUE(contains(no_intrinsics, cameras[0].depth[0].string())) << no_intrinsics;
  EXPECT_TRUE(contains(no_intrinsics, "intrinsics")) << no_intrinsics;
  EXPECT_TRUE(list_folder_cameras(test::hands_dir()).empty());  // an image sequence
  EXPECT_TRUE(list_folder_cameras("/nonexistent/folder").empty());
}

TEST(CameraFolder, AKinectOfTheFourStreamsWithTheRecordingsLensModel) {
  const auto cameras = list_folder_cameras(four_cameras());
  ASSERT_EQ(cameras.size(), 4u);
  SourceOptions o;
  o.intrinsics = kinect();
  o.world_from_camera = RigidTransform{rotation_from_degrees({0, 45, 0}), {1, 0, 2}};
  const auto source = open_source(cameras[1].depth[0], o);
  EXPECT_EQ(source->calibration().depth, *o.intrinsics);  // 640x576, every lens term
  EXPECT_EQ(source->calibration().depth.width, 640);
  EXPECT_EQ(source->calibration().depth.height, 576);
  EXPECT_TRUE(source->calibration().world_from_camera.translation.isApprox(
      o.world_from_camera->translation));
  EXPECT_EQ(source->frame_count(), 1);
  EXPECT_EQ(source->color_frame_count(), 1);
  EXPECT_DOUBLE_EQ(source->fps(), 30);
  CameraFrame f;
  source->next(f);
  EXPECT_EQ(f.depth, read_depth_png(cameras[1].depth[0]));
  EXPECT_EQ(f.color.width, 640);  // 1280x720 resampled to the depth grid (not registered)
  EXPECT_EQ(f.color.height, 576);
  const int64_t t0 = f.device_timestamp_us;
  source->next(f);  // loops: the same frame again, 1/30 s later
  EXPECT_EQ(f.depth, read_depth_png(cameras[1].depth[0]));
  EXPECT_GT(f.device_timestamp_us, t0);
  // Intrinsics for another image size are refused.
  SourceOptions wrong = o;
  wrong.intrinsics->width = 320;
  const std::string e = test::error_of([&] { open_source(cameras[1].depth[0], wrong); });
  EXPECT_TRUE(contains(e, "640x576")) << e;
}

TEST(CameraFolder, FramesPlayInNameOrderLoopAndBadOnesAreNamedAndSkipped) {
  // SYNTHETIC: camera A has frames 0001..0004 (0003 of another size, 0004 not a PNG), camera B
  // one frame and an unrelated PNG sits beside them.
  const fs::path dir = test::temp_dir("camera_folder");
  for (int i = 1; i <= 2; ++i) {
    DepthImage d(4, 3);
    d.pixels.assign(d.size(), static_cast<uint16_t>(1000 * i));
    write_depth_png(dir / ("depth.A-000" + std::to_string(i) + ".png"), d);
  }
  write_depth_png(dir / "depth.A-0003.png", DepthImage(5, 3));
  write_text(dir / "depth.A-0004.png", "not a png");
  write_depth_png(dir / "depth.B-0001.png", DepthImage(4, 3));
  ColorImage color(8, 6);
  color.bgra.assign(color.bgra.size(), 200);
  write_color_png(dir / "rgb.A-0002.png", color);
  DepthImage other(2, 2);
  other.pixels = {1, 2, 3, 4};
  write_depth_png(dir / "other.png", other);

  const auto cameras = list_folder_cameras(dir);
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].serial, "A");
  EXPECT_EQ(cameras[0].depth.size(), 4u);
  EXPECT_TRUE(cameras[0].color[0].empty());
  EXPECT_EQ(cameras[0].color[1].filename(), "rgb.A-0002.png");
  EXPECT_EQ(cameras[1].serial, "B");

  SourceOptions o;
  o.intrinsics = Intrinsics{};
  o.intrinsics->fx = o.intrinsics->fy = 3;
  o.fps = 10;
  auto a = open_source(dir / "depth.A-0002.png", o);  // any frame names the camera
  EXPECT_EQ(a->frame_count(), 4);
  EXPECT_EQ(a->color_frame_count(), 1);
  EXPECT_EQ(a->calibration().depth.width, 4);
  CameraFrame f;
  a->next(f);
  EXPECT_EQ(f.depth.pixels[0], 1000);
  EXPECT_TRUE(f.color.empty());
  EXPECT_EQ(f.device_timestamp_us, 0);
  a->next(f);
  EXPECT_EQ(f.depth.pixels[0], 2000);
  EXPECT_EQ(f.color.width, 4);  // resampled to the depth grid
  EXPECT_EQ(f.color.pixel(3, 2)[0], 200);
  EXPECT_EQ(f.device_timestamp_us, 100000);
  const std::string size = test::error_of([&] { a->next(f); });
  EXPECT_TRUE(contains(size, "depth.A-0003.png")) << size;
  EXPECT_TRUE(contains(size, "5x3")) << size;
  const std::string corrupt = test::error_of([&] { a->next(f); });
  EXPECT_TRUE(contains(corrupt, "depth.A-0004.png")) << corrupt;
  a->next(f);  // looped past the bad frames
  EXPECT_EQ(f.depth.pixels[0], 1000);
  a->next(f);
  EXPECT_EQ(f.depth.pixels[0], 2000);

  // Any other PNG: one still frame, no color.
  auto still = open_source(dir / "other.png", o);
  EXPECT_EQ(still->frame_count(), 1);
  EXPECT_EQ(still->color_frame_count(), 0);
  EXPECT_EQ(still->next().depth, other);
  EXPECT_EQ(still->next().depth, other);
  // The folder itself is refused, naming its two cameras.
  EXPECT_TRUE(contains(test::error_of([&] { open_source(dir); }), "2 cameras"));
  // A corrupt single frame is named when opened.
  write_text(dir / "depth.C-0001.png", "garbage");
  EXPECT_TRUE(
      contains(test::error_of([&] { open_source(dir / "depth.C-0001.png", o); }), "depth.C-0001"));
}

TEST(CameraFolder, ServeStreamsTheFourKinectsFromASiteConfig) {
  // A site config as calibrate writes it, its sources relative to its own folder ("cams" links
  // to the shared set), read by serve started from another working directory.
  const fs::path dir = test::temp_dir("camera_folder_serve");
  fs::create_directory_symlink(four_cameras(), dir / "cams");
  std::vector<SiteCamera> site;
  for (const FolderCamera& c : list_folder_cameras(four_cameras())) {
    SiteCamera s;
    s.source = "cams/" + c.depth[0].filename().string();
    s.name = c.serial;
    s.intrinsics = kinect();
    s.world_from_camera =
        RigidTransform{rotation_from_degrees({0, 90.0 * static_cast<double>(site.size()), 0}),
                       {1.5 * static_cast<double>(site.size()), 1.2, 0}};
    s.registration = SiteRegistration{"targetless", -1, 6.5};
    site.push_back(s);
  }
  ASSERT_EQ(site.size(), 4u);
  write_site_config(dir / "site.json", site);
  std::string out;
  ASSERT_EQ(test::run_command("cd / && ASAN_OPTIONS=detect_leaks=0 " + kVolcast +
                                  " serve --insecure --port 0 --seconds 1 --config " +
                                  (dir / "site.json").string(),
                              out),
            0)
      << out;
  size_t placed = 0;
  for (size_t at = out.find("placed by the site config"); at != std::string::npos;
       at = out.find("placed by the site config", at + 1))
    ++placed;
  EXPECT_EQ(placed, 4u) << out;
  EXPECT_TRUE(contains(out, "serving 4 camera(s)")) << out;
  EXPECT_TRUE(contains(out, "Brown-Conrady")) << out;
  EXPECT_FALSE(contains(out, "NO COLOR")) << out;
}

}  // namespace
}  // namespace volcast
