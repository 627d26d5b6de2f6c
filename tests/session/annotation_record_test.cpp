// `volcast record --session` records the session's drawing (recording.hpp Drawing records): the
// annotations standing when it joins and each one drawn and erased afterwards, as the session
// carried them, with a Speaker record naming their author; `export --annotations` lists them.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>

#include "support/session_site.hpp"
#include "support/test_paths.hpp"
#include "support/voice_recorder.hpp"
#include "volcast/pipeline/annotation_export.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/session/annotations.hpp"

namespace volcast {
namespace {

using namespace std::chrono_literals;
using session::Annotation;
using session::AnnotationKind;
using test::eventually;

TEST(Annotations, TheRecorderRecordsTheSessionsDrawingAndExportListsIt) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("annotation_record_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "drawing.vcr").string();
  std::vector<Annotation> drawn(2);  // synthetic (labelled): a label, then a stroke
  drawn[0].kind = AnnotationKind::kLabel;
  drawn[0].points = {{0.25f, 1.125f, -0.375f}};
  drawn[0].text = "keep clear";
  drawn[1].points = {{0.1234567f, 1.0f, -0.25f}, {0.15f, 1.01f, -0.26f}, {0.2f, 1.02f, -0.3f}};
  {
    test::SessionSite s({}, 5);
    test::TestParticipant a(s, test::hand_driven("Mentor"));
    ASSERT_TRUE(eventually([&] { return a.now().joined; }, 30s));
    a.p().annotate(drawn[0]);  // before the recorder joins: it gets it on joining
    ASSERT_TRUE(eventually([&] { return a.now().annotations.size() == 1; }, 30s));
    const pid_t pid = test::spawn_recorder(s.link(), file);
    ASSERT_NE(pid, 0);
    ASSERT_TRUE(eventually([&] { return a.other("Recorder").has_value(); }, 30s));
    a.p().annotate(drawn[1]);
    ASSERT_TRUE(eventually([&] { return a.now().annotations.size() == 2; }, 30s));
    const uint32_t label_id = a.now().annotations[0].id;
    a.p().erase(label_id);
    ASSERT_TRUE(eventually([&] { return a.now().annotations.size() == 1; }, 30s));
    std::this_thread::sleep_for(300ms);  // the erasure's way to the recorder
    kill(pid, SIGTERM);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  }
  RecordingReader r(file);
  EXPECT_EQ(r.info().version, 3);
  ASSERT_EQ(r.info().drawings.size(), 3u);
  EXPECT_EQ(r.info().drawings[0].type, 0x51);
  EXPECT_EQ(r.info().drawings[1].type, 0x51);
  EXPECT_EQ(r.info().drawings[2].type, 0x52);
  ASSERT_EQ(r.info().speakers.size(), 1u);
  EXPECT_EQ(r.info().speakers[0].name, "Mentor");
  const std::vector<RecordedAnnotation> all = recorded_annotations(r);
  ASSERT_EQ(all.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(all[k].annotation.points, drawn[k].points);  // exactly: f32 all the way
    EXPECT_EQ(all[k].annotation.author, r.info().speakers[0].participant);
  }
  EXPECT_EQ(all[0].annotation.text, "keep clear");
  ASSERT_TRUE(all[0].erased_us.has_value());
  EXPECT_GE(*all[0].erased_us, all[1].received_us);
  EXPECT_EQ(all[0].erased_by, r.info().speakers[0].participant);
  EXPECT_FALSE(all[1].erased_us.has_value());
  // The CLI's export writes them.
  const std::string json = (dir / "annotations.json").string();
  const std::string command =
      std::string(test::paths::volcast()) + " export " + file + " --annotations " + json + " > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  ASSERT_EQ(j["annotations"].size(), 2u);
  EXPECT_EQ(j["annotations"][0]["author"]["name"], "Mentor");
  EXPECT_EQ(j["annotations"][1]["kind"], "stroke");
  EXPECT_EQ(j["annotations"][1]["points"][0][0].get<double>(), 0.1234567);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace volcast
