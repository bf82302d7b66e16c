// Checkpoints and `snowsim resume`, as a user meets them: a run killed at any moment and resumed
// ends with the very frames of an uninterrupted run; a damaged or foreign checkpoint is refused
// before anything is written; a full disk keeps the last checkpoint.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sim/io/checkpoint.h"
#include "tests/support/run_snowsim.h"
#include "tests/support/threaded_test.h"

namespace fs = std::filesystem;
using snowsim_test::bytesOf;
using snowsim_test::frames;
using snowsim_test::freshDir;
using snowsim_test::runSnowsim;
using snowsim_test::startSnowsim;

namespace {

std::string sceneFile(const std::string& name) {
  return std::string(SNOWSIM_SOURCE_DIR) + "/scenes/" + name + ".json";
}

// Waits (up to a minute) until `path` exists, then `delay` more; false if it never appeared.
bool waitFor(const fs::path& path, std::chrono::milliseconds delay = {}) {
  for (int i = 0; i < 30000 && !fs::exists(path); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  std::this_thread::sleep_for(delay);
  return fs::exists(path);
}

int finish(pid_t child, int sig) {
  kill(child, sig);
  int status = 0;
  waitpid(child, &status, 0);
  return status;
}

std::string frameName(int frame, const char* extension) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.%s", frame, extension);
  return name;
}

struct Case {
  std::string name, scene;
  std::vector<std::string> settings;  // options that keep it to seconds
};

// Tiny runs of each method and dimension, many steps per frame so that a kill lands mid-frame.
const Case kCases[] = {
    {"report_2d",
     "snowball_drop",
     {"--set", "time.duration=0.4", "--set", "time.fps=25", "--set", "time.dt=0.0001"}},
    {"mpm_2d", "mpm_reference", {"--set", "time.duration=0.16", "--set", "time.fps=50"}},
    {"mpm_3d",
     "mpm_snowball_wall",
     {"--scale", "0.5", "--set", "time.duration=0.1", "--set", "time.fps=100"}},
};

std::vector<std::string> runArgs(const Case& c, const fs::path& out, int threads) {
  std::vector<std::string> args = {"run",
                                   sceneFile(c.scene),
                                   "-o",
                                   out.string(),
                                   "--width",
                                   "48",
                                   "--height",
                                   "32",
                                   "--no-mp4",
                                   "--threads",
                                   std::to_string(threads),
                                   "--checkpoint-every",
                                   "1"};
  args.insert(args.end(), c.settings.begin(), c.settings.end());
  return args;
}

// The checkpoint in `dir` as the run layer wrote it: its run state (next_frame: the frame resume
// writes first; earlier_sessions: the times of the sessions so far).
nlohmann::json runStateOf(const fs::path& dir) {
  const fs::path file = dir / "checkpoint.snowsim";
  return nlohmann::json::parse(snowsim::decodeCheckpoint(bytesOf(file), file).run_state);
}

std::string commandLine(const std::vector<std::string>& args) {
  std::string line;
  for (const std::string& a : args) line += " '" + a + "'";
  return line;
}

}  // namespace

// A checkpoint streamed to its file, its solver state counted first and never held whole, has
// the bytes of the same checkpoint encoded at once; the one before stays as .prev. A state that
// changes its length between the count and the write is an internal error that leaves the
// checkpoint as it was.
THREADED_TEST(Checkpoint, AStreamedCheckpointHasTheBytesOfOneEncodedWhole) {
  const fs::path dir = freshDir("streamed");
  fs::create_directories(dir);
  const std::string path = (dir / "checkpoint.snowsim").string();
  snowsim::CheckpointHeader header;
  header.dimension = 3;
  header.scalar_bytes = 4;
  header.scene_hash = 0x1234;
  header.snowsim_version = "test";
  std::vector<double> large(300000);  // 2.4 MB: past the file's buffer
  for (size_t i = 0; i < large.size(); ++i) large[i] = 0.5 * double(i);
  int saves = 0;
  const auto save = [&](snowsim::StateWriter& out) {
    ++saves;
    out.value(std::uint32_t{7});
    out.array(large);
    out.array(std::vector<int>{});
    out.value(2.5f);
  };
  snowsim::StateWriter kept;
  save(kept);
  const std::string expected = snowsim::encodeCheckpoint({header, "{\"run\": 1}", kept.bytes()});
  saves = 0;
  snowsim::writeCheckpoint(path, header, "{\"run\": 1}", save);
  EXPECT_EQ(saves, 2);
  ASSERT_EQ(bytesOf(path), expected);
  EXPECT_EQ(snowsim::decodeCheckpoint(expected, path).solver_state, kept.bytes());

  large[0] = 1;
  snowsim::writeCheckpoint(path, header, "{\"run\": 2}", save);
  EXPECT_EQ(bytesOf(path + ".prev"), expected);
  const std::string second = bytesOf(path);
  EXPECT_NE(second, expected);

  bool longer = false;
  const auto unsteady = [&](snowsim::StateWriter& out) {
    out.array(std::vector<int>(longer ? 3 : 2));
    longer = true;
  };
  EXPECT_THROW(snowsim::writeCheckpoint(path, header, "{}", unsteady), std::logic_error);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  EXPECT_EQ(bytesOf(path), second);
  // A save that fails while writing (out of memory, say) leaves nothing behind either.
  int calls = 0;
  const auto failing = [&](snowsim::StateWriter& out) {
    out.array(large);
    if (++calls == 2) throw std::bad_alloc();
  };
  EXPECT_THROW(snowsim::writeCheckpoint(path, header, "{}", failing), std::bad_alloc);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  EXPECT_EQ(bytesOf(path), second);
}

// Killed with SIGKILL at several moments (after k frames, and some milliseconds into the next
// frame's steps) and resumed, on one and two threads: every PLY and PNG byte for byte as the
// uninterrupted run's. Each kill leaves a later checkpoint than the one before it.
THREADED_TEST(Checkpoint, ResumeAfterSigkillWritesTheFramesOfAnUninterruptedRun) {
  for (const Case& c : kCases) {
    const fs::path whole = freshDir("whole_" + c.name);
    const auto reference = runSnowsim(commandLine(runArgs(c, whole, 1)).substr(1));
    ASSERT_EQ(reference.code, 0) << reference.output;
    const auto expected = frames(whole);
    ASSERT_GT(expected.size(), 8u);
    EXPECT_FALSE(fs::exists(whole / "checkpoint.snowsim")) << "a complete run keeps none";
    for (int threads : {1, 2}) {
      int previous_kill_resumes_at = 0;
      for (const auto& [after_frame, delay_ms] : {std::pair{1, 0}, {3, 7}}) {
        SCOPED_TRACE(c.name + ", " + std::to_string(threads) + " threads, killed after frame " +
                     std::to_string(after_frame) + " + " + std::to_string(delay_ms) + " ms");
        // A kill that a loaded machine let run on to the previous kill's checkpoint would test
        // that moment twice, and one it let run to the last frame would test nothing: either is
        // killed again (at most five tries).
        fs::path out;
        int resumes_at = 0;
        for (int attempt = 0; attempt < 5; ++attempt) {
          out = freshDir("killed_" + c.name);
          const pid_t child = startSnowsim(runArgs(c, out, threads));
          const int frame = std::max(after_frame, previous_kill_resumes_at);
          ASSERT_TRUE(waitFor(out / frameName(frame, "png"), std::chrono::milliseconds(delay_ms)));
          finish(child, SIGKILL);
          if (frames(out).size() == expected.size()) continue;
          ASSERT_TRUE(fs::exists(out / "checkpoint.snowsim"));
          resumes_at = runStateOf(out)["next_frame"].get<int>();
          if (resumes_at > previous_kill_resumes_at) break;
        }
        EXPECT_GT(resumes_at, previous_kill_resumes_at) << "the kill points do not differ";
        previous_kill_resumes_at = resumes_at;
        ASSERT_NE(frames(out).size(), expected.size()) << "killed too late to test anything";
        const auto resumed =
            runSnowsim("resume " + out.string() + " --threads " + std::to_string(threads));
        ASSERT_EQ(resumed.code, 0) << resumed.output;
        EXPECT_EQ(frames(out), expected);
        EXPECT_FALSE(fs::exists(out / "checkpoint.snowsim"));
      }
    }
  }
}

// The scene's output object sets the cadence; the command line overrides it. Killed with
// SIGKILL after some frames, a run checkpointing every frame by its scene has a checkpoint to
// resume from, one told otherwise by --checkpoint-every 0 --checkpoint-minutes 0 has none.
THREADED_TEST(Checkpoint, TheSceneSetsTheCadenceAndTheCommandLineOverridesIt) {
  const auto killedAfterFrame3 = [](const std::string& name, std::vector<std::string> extra) {
    const fs::path out = freshDir(name);
    std::vector<std::string> args = runArgs(kCases[0], out, 1);
    args.resize(args.size() - kCases[0].settings.size() - 2);  // without --checkpoint-every 1
    args.insert(args.end(), kCases[0].settings.begin(), kCases[0].settings.end());
    args.insert(args.end(), {"--set", "output.checkpoint_every_frames=1"});
    args.insert(args.end(), extra.begin(), extra.end());
    const pid_t child = startSnowsim(args);
    EXPECT_TRUE(waitFor(out / frameName(3, "png")));
    finish(child, SIGKILL);
    return out;
  };
  const fs::path by_scene = killedAfterFrame3("cadence_scene", {});
  EXPECT_TRUE(fs::exists(by_scene / "checkpoint.snowsim"));
  const fs::path overridden = killedAfterFrame3(
      "cadence_overridden", {"--checkpoint-every", "0", "--checkpoint-minutes", "0"});
  EXPECT_TRUE(fs::exists(overridden / frameName(3, "png")));
  EXPECT_FALSE(fs::exists(overridden / "checkpoint.snowsim"));

  const auto refused =
      runSnowsim("run " + sceneFile("snowball_drop") + " -o " + freshDir("cadence_bad").string() +
                 " --set output.checkpoint_minutes=-2");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("output.checkpoint_minutes: -2 is out of range"), std::string::npos)
      << refused.output;
}

// SIGTERM stops mid-frame at the end of a step; the checkpoint holds that state, and resume lands
// on the same steps (the last one shortened to the frame's time as before).
THREADED_TEST(Checkpoint, ResumeAfterSigtermMidFrameWritesTheSameFrames) {
  // Twenty seconds of snow a frame, some 90,000 steps (about half a second): a stop lands between
  // frames.
  const auto args = [](const fs::path& out, int threads) {
    return std::vector<std::string>{"run",
                                    sceneFile("mpm_reference"),
                                    "-o",
                                    out.string(),
                                    "--no-png",
                                    "--no-mp4",
                                    "--set",
                                    "time.duration=40",
                                    "--set",
                                    "time.fps=0.05",
                                    "--checkpoint-minutes",
                                    "0",
                                    "--threads",
                                    std::to_string(threads)};
  };
  const fs::path whole = freshDir("whole_sigterm");
  ASSERT_EQ(runSnowsim(commandLine(args(whole, 1)).substr(1)).code, 0);
  const fs::path out = freshDir("sigterm");
  const pid_t child = startSnowsim(args(out, 2));
  ASSERT_TRUE(waitFor(out / frameName(0, "ply"), std::chrono::milliseconds(200)));
  const int status = finish(child, SIGTERM);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 128 + SIGTERM) << "the run ended before the signal";
  const auto stopped = nlohmann::json::parse(std::ifstream(out / "run.json"));
  const double stopped_at = stopped["simulated_time"].get<double>();
  EXPECT_NE(stopped_at, 20 * std::round(stopped_at / 20)) << "stopped at a frame, not between";
  const nlohmann::json first_session = runStateOf(out)["earlier_sessions"];
  const auto resume_start = std::chrono::steady_clock::now();
  const auto resumed = runSnowsim("resume " + out.string() + " --threads 1");
  const double resume_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - resume_start).count();
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(frames(out), frames(whole));
  // Its cost is said of what was left, and timed over its own first steps.
  std::smatch left;
  ASSERT_TRUE(std::regex_search(resumed.output, left,
                                std::regex("; ([0-9.e+-]+) s left to simulate at a first step")))
      << resumed.output;
  EXPECT_NEAR(std::stod(left[1]), 40 - stopped_at, 0.2) << resumed.output;  // 3 digits
  EXPECT_NE(resumed.output.find("estimate: the steps take about"), std::string::npos)
      << resumed.output;
  const auto summary = nlohmann::json::parse(std::ifstream(out / "run.json"));
  const auto uninterrupted = nlohmann::json::parse(std::ifstream(whole / "run.json"));
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_EQ(summary["resumed_at_frame"], stopped["frames"]);
  EXPECT_FALSE(summary.contains("interrupted_by_signal"));
  // The step statistics are the whole run's, as the uninterrupted run's.
  EXPECT_EQ(summary["steps"], uninterrupted["steps"]);
  EXPECT_EQ(summary["step_size"], uninterrupted["step_size"]);
  // The times add up both sessions: the first one's up to its checkpoint, which it spent
  // stepping (its "step" stages) and checkpointing, and the resumed one's.
  EXPECT_EQ(summary["sessions"], 2);
  EXPECT_EQ(first_session["sessions"], 1);
  const double first_wall = first_session["wall_time"].get<double>();
  EXPECT_GT(first_wall, 0.2) << "the first session ran 0.2 s past its first frame";
  EXPECT_GE(summary["wall_time"].get<double>(), first_wall);
  EXPECT_LE(summary["wall_time"].get<double>(), first_wall + resume_seconds);
  std::map<std::string, double> seconds_by_stage;
  for (const auto& stage : summary["stages"])
    seconds_by_stage[stage["stage"].get<std::string>()] = stage["seconds"].get<double>();
  double first_stages = 0;
  for (const auto& stage : first_session["stages"]) {
    const std::string name = stage["stage"];
    SCOPED_TRACE(name);
    ASSERT_TRUE(seconds_by_stage.contains(name));
    EXPECT_GE(seconds_by_stage[name], stage["seconds"].get<double>());
    first_stages += stage["seconds"].get<double>();
  }
  EXPECT_GT(first_stages, 0.5 * first_wall) << "the first session's stages are not counted";
}

// A run holds its directory: a second run, an --overwrite or a resume into it while it goes is
// refused and writes nothing; once it has stopped, the resume continues it. The run is held still
// (SIGSTOP) while the others try, so that it cannot end first on a slow machine.
THREADED_TEST(Checkpoint, ARunningRunsDirectoryIsRefusedToASecondRunAndToResume) {
  const fs::path out = freshDir("held");
  const std::vector<std::string> args{
      "run",   sceneFile("mpm_reference"), "-o",    out.string(),   "--no-png", "--no-mp4",
      "--set", "time.duration=40",         "--set", "time.fps=0.05"};
  const pid_t child = startSnowsim(args);
  ASSERT_TRUE(waitFor(out / frameName(0, "ply")));
  kill(child, SIGSTOP);
  const std::string frame = bytesOf(out / frameName(0, "ply"));
  const std::string second = "run " + sceneFile("mpm_reference") + " -o " + out.string() +
                             " --no-png --no-mp4 --set time.duration=0.1";
  for (const std::string& command : {second, second + " --overwrite", "resume " + out.string()}) {
    SCOPED_TRACE(command);
    const auto r = runSnowsim(command);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(out.string() + ": another snowsim run or resume is writing into it " +
                            "(process " + std::to_string(child) + " holds"),
              std::string::npos)
        << r.output;
  }
  EXPECT_EQ(bytesOf(out / frameName(0, "ply")), frame) << "a refused command wrote the frame";
  EXPECT_FALSE(fs::exists(out / "run.json")) << "a refused command wrote run.json";
  kill(child, SIGTERM);  // delivered once it runs again
  const int status = finish(child, SIGCONT);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
  EXPECT_FALSE(fs::exists(out / ".snowsim.lock")) << "left by a run a signal stopped";
  const auto resumed = runSnowsim("resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(out / "run.json"))["frames"], 3);
  EXPECT_FALSE(fs::exists(out / ".snowsim.lock")) << "left by a resume that ended";
}

// The lock file names its run's process; a run killed at once (SIGKILL, or a second signal,
// which ends it past its destructors) leaves none that stands in the way: the second signal
// removes it, and one left by SIGKILL names a process that no longer runs and holds no lock.
THREADED_TEST(Checkpoint, ALockLeftByAKilledRunDoesNotHoldTheDirectory) {
  const fs::path out = freshDir("stale_lock");
  const fs::path lock = out / ".snowsim.lock";
  const std::vector<std::string> args{
      "run",   sceneFile("mpm_reference"), "-o",    out.string(),   "--no-png", "--no-mp4",
      "--set", "time.duration=40",         "--set", "time.fps=0.05"};
  pid_t child = startSnowsim(args);
  ASSERT_TRUE(waitFor(out / frameName(0, "ply")));
  EXPECT_EQ(bytesOf(lock), std::to_string(child) + "\n");
  finish(child, SIGKILL);
  ASSERT_EQ(bytesOf(lock), std::to_string(child) + "\n");
  const std::string again = "run " + sceneFile("mpm_reference") + " -o " + out.string() +
                            " --overwrite --no-png --no-mp4 --set time.duration=0.02";
  auto r = runSnowsim(again);
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find(lock.string() + ": left by process " + std::to_string(child) +
                          ", which no longer runs; taken over"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(lock));

  // Two signals while it is held still: the second ends it at once, without run.json.
  const fs::path at_once = freshDir("stale_lock_at_once");
  std::vector<std::string> into = args;
  into[3] = at_once.string();
  child = startSnowsim(into);
  ASSERT_TRUE(waitFor(at_once / frameName(0, "ply")));
  kill(child, SIGSTOP);
  kill(child, SIGTERM);
  kill(child, SIGINT);
  const int status = finish(child, SIGCONT);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_TRUE(WEXITSTATUS(status) == 128 + SIGTERM || WEXITSTATUS(status) == 128 + SIGINT);
  EXPECT_FALSE(fs::exists(at_once / "run.json")) << "the run did not stop at once";
  EXPECT_FALSE(fs::exists(at_once / ".snowsim.lock")) << "left by a run a second signal ended";
}

// The MP4 of a killed and resumed run holds every frame once: ffprobe counts as many as PNGs.
THREADED_TEST(Checkpoint, TheVideoOfAResumedRunHoldsEveryFrameOnce) {
  const fs::path out = freshDir("video");
  std::vector<std::string> args = runArgs(kCases[0], out, 1);
  std::erase(args, std::string("--no-mp4"));
  const pid_t child = startSnowsim(args);
  ASSERT_TRUE(waitFor(out / frameName(4, "png")));
  finish(child, SIGKILL);
  ASSERT_FALSE(fs::exists(out / "snowball_drop.mp4"));
  const auto resumed = runSnowsim("resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  int pngs = 0;
  for (const auto& [name, bytes] : frames(out)) pngs += name.ends_with(".png");
  const auto probe = snowsim_test::runCommand(
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames "
      "-of csv=p=0 " +
      (out / "snowball_drop.mp4").string());
  EXPECT_EQ(std::stoi(probe.output), pngs) << probe.output;
  EXPECT_EQ(pngs, 11);
}

// The decoded pictures of a video, one MD5 a frame (ffmpeg's framemd5, without its header).
std::string pictureHashes(const fs::path& video) {
  const auto hashes = snowsim_test::runCommand("ffmpeg -v error -i " + video.string() +
                                               " -f framemd5 - | grep -v '^#'");
  return hashes.output;
}

// A run that writes its MP4 but no PNGs, killed and resumed: the video's first frames are drawn
// again from the PLY frames (colliders included), to the very pictures of an uninterrupted run.
THREADED_TEST(Checkpoint, AResumedRunWithoutPngsRedrawsItsVideoFromThePly) {
  const fs::path out = freshDir("video_from_ply"), whole = freshDir("video_from_ply_whole");
  std::vector<std::string> args = runArgs(kCases[2], out, 1);
  std::erase(args, std::string("--no-mp4"));
  args.push_back("--no-png");
  const pid_t child = startSnowsim(args);
  ASSERT_TRUE(waitFor(out / frameName(4, "ply")));
  finish(child, SIGKILL);
  // A frame the video is rebuilt from gone: refused before anything is written.
  fs::rename(out / frameName(1, "ply"), out / "aside.ply");
  const auto before = frames(out);
  const auto refused = runSnowsim("resume " + out.string());
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find(frameName(1, "ply") + ": missing"), std::string::npos)
      << refused.output;
  EXPECT_EQ(frames(out), before);
  fs::rename(out / "aside.ply", out / frameName(1, "ply"));
  const auto resumed = runSnowsim("resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  std::vector<std::string> uninterrupted = runArgs(kCases[2], whole, 1);
  std::erase(uninterrupted, std::string("--no-mp4"));
  uninterrupted.push_back("--no-png");
  ASSERT_EQ(runSnowsim(commandLine(uninterrupted)).code, 0);
  const std::string hashes = pictureHashes(out / "mpm_snowball_wall.mp4");
  EXPECT_EQ(std::count(hashes.begin(), hashes.end(), '\n'), 11) << hashes;
  EXPECT_EQ(hashes, pictureHashes(whole / "mpm_snowball_wall.mp4"));
}

// A run that writes nothing but its MP4 cannot rebuild the video's first frames: resume says so
// and names --no-mp4, which goes on without the video, leaving the stopped run's video of its
// first frames as it was, and later resumes of it too.
THREADED_TEST(Checkpoint, AVideoOnlyRunResumesWithoutItsVideoWhenAsked) {
  const fs::path out = freshDir("video_only");
  std::vector<std::string> args = runArgs(kCases[2], out, 1);
  std::erase(args, std::string("--no-mp4"));
  args.insert(args.end(), {"--no-png", "--no-ply", "--set", "time.duration=0.3"});
  const fs::path log = out.parent_path() / "video_only.log";
  const pid_t child = startSnowsim(args, log.string());
  ASSERT_TRUE(waitFor(out / "checkpoint.snowsim"));
  const int status = finish(child, SIGTERM);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 128 + SIGTERM) << "the run ended before it was stopped";
  const std::string stopped = bytesOf(log);
  EXPECT_NE(stopped.find("snowsim resume " + out.string() + " --no-mp4 continues it"),
            std::string::npos)
      << stopped;
  const std::string stopped_video = bytesOf(out / "mpm_snowball_wall.mp4");
  const auto refused = runSnowsim("resume " + out.string());
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("--no-mp4"), std::string::npos) << refused.output;
  // Stopped again, the run resumes without --no-mp4: its recorded command line carries it.
  const int stopped_at = runStateOf(out)["next_frame"];
  const fs::path second_log = out.parent_path() / "video_only_resumed.log";
  const pid_t again = startSnowsim({"resume", out.string(), "--no-mp4"}, second_log.string());
  for (int i = 0; i < 30000 && runStateOf(out)["next_frame"] == stopped_at; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const int second_status = finish(again, SIGTERM);
  ASSERT_TRUE(WIFEXITED(second_status));
  ASSERT_EQ(WEXITSTATUS(second_status), 128 + SIGTERM) << "the resumed run ended before the stop";
  const std::string stopped_again = bytesOf(second_log);
  EXPECT_NE(stopped_again.find("snowsim resume " + out.string() + " continues it"),
            std::string::npos)
      << stopped_again;
  const auto resumed = runSnowsim("resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_FALSE(
      nlohmann::json::parse(std::ifstream(out / "run.json")).contains("interrupted_by_signal"));
  EXPECT_EQ(bytesOf(out / "mpm_snowball_wall.mp4"), stopped_video) << "the stopped run's video";
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_FALSE(entry.path().filename().string().ends_with(".part")) << entry.path();
}

// A checkpoint that is truncated, corrupted, of another format or snowsim version, of another
// scene or with a damaged record of its sessions: exit 2, a message naming it, and not a byte of
// the run's frames changed.
THREADED_TEST(Checkpoint, ADamagedOrForeignCheckpointIsRefusedAndNothingIsWritten) {
  const fs::path out = freshDir("damaged");
  const pid_t child = startSnowsim(runArgs(kCases[0], out, 1));
  ASSERT_TRUE(waitFor(out / frameName(2, "png")));
  finish(child, SIGKILL);
  const fs::path file = out / "checkpoint.snowsim";
  const std::string good = bytesOf(file);
  const snowsim::Checkpoint decoded = snowsim::decodeCheckpoint(good, "good");
  const auto frames_before = frames(out);

  std::string corrupted = good;
  corrupted[corrupted.size() / 2] ^= 0x10;
  std::string other_format = good;
  other_format[8] = 9;  // the format version follows the magic
  snowsim::Checkpoint other_version = decoded;
  other_version.header.snowsim_version = "0.0.1";
  snowsim::Checkpoint other_scene = decoded;
  other_scene.header.scene_hash ^= 1;
  snowsim::Checkpoint bad_sessions = decoded;
  auto run_state = nlohmann::json::parse(decoded.run_state);
  ASSERT_TRUE(run_state.contains("earlier_sessions"));
  run_state["earlier_sessions"]["stages"] = "none";
  bad_sessions.run_state = run_state.dump();
  const std::pair<std::string, std::string> cases[] = {
      {good.substr(0, good.size() / 3), "truncated"},
      {good.substr(0, 10), "truncated"},
      {corrupted, "corrupted"},
      {"{\"not\": \"a checkpoint\"}", "not a snowsim checkpoint"},
      {other_format, "format 9"},
      {snowsim::encodeCheckpoint(other_version), "written by snowsim 0.0.1"},
      {snowsim::encodeCheckpoint(other_scene), "another scene"},
      {snowsim::encodeCheckpoint(bad_sessions), "earlier sessions' times"},
  };
  for (const auto& [bytes, problem] : cases) {
    SCOPED_TRACE(problem);
    std::ofstream(file, std::ios::binary) << bytes;
    const auto r = runSnowsim("resume " + out.string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(file.string() + ": "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(problem), std::string::npos) << r.output;
    EXPECT_EQ(frames(out), frames_before);
  }
  // Damaged, it names the checkpoint before it (the kill may come before the writer kept one).
  std::ofstream(out / "checkpoint.snowsim.prev", std::ios::binary) << good;
  std::ofstream(file, std::ios::binary) << corrupted;
  const auto damaged = runSnowsim("resume " + out.string());
  EXPECT_NE(damaged.output.find("mv " + file.string() + ".prev " + file.string()),
            std::string::npos)
      << damaged.output;
  std::ofstream(file, std::ios::binary) << other_format;  // not damaged: the one before is alike
  EXPECT_EQ(runSnowsim("resume " + out.string()).output.find(".prev"), std::string::npos);
  // Following the hint resumes.
  fs::rename(out / "checkpoint.snowsim.prev", file);
  const auto from_previous = runSnowsim("resume " + out.string());
  EXPECT_EQ(from_previous.code, 0) << from_previous.output;
  fs::remove(file);
  const auto missing = runSnowsim("resume " + out.string());
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.output.find("no checkpoint"), std::string::npos) << missing.output;

  // Another run's checkpoint in a directory whose run.json records its own scene.
  const fs::path other = freshDir("damaged_other");
  const pid_t stopped = startSnowsim(runArgs(kCases[1], other, 1));
  ASSERT_TRUE(waitFor(other / frameName(1, "png")));
  finish(stopped, SIGTERM);
  ASSERT_TRUE(fs::exists(other / "run.json"));
  std::ofstream(other / "checkpoint.snowsim", std::ios::binary) << good;
  const auto foreign = runSnowsim("resume " + other.string());
  EXPECT_EQ(foreign.code, 2) << foreign.output;
  EXPECT_NE(foreign.output.find("of another scene than " + other.string() + "/run.json"),
            std::string::npos)
      << foreign.output;
}

// The disk fills up mid-run as the next checkpoint is written (its temporary file a link to
// /dev/full): a message naming the file, exit 2, the earlier checkpoint intact, and resuming from
// it (with room again) ends with the uninterrupted run's frames.
THREADED_TEST(Checkpoint, AFullDiskKeepsTheLastCheckpoint) {
  const Case& c = kCases[0];
  const fs::path whole = freshDir("full_whole");
  ASSERT_EQ(runSnowsim(commandLine(runArgs(c, whole, 1)).substr(1)).code, 0);
  const fs::path out = freshDir("full");
  const pid_t child = startSnowsim(runArgs(c, out, 1));
  ASSERT_TRUE(waitFor(out / "checkpoint.snowsim"));
  const fs::path temporary = out / "checkpoint.snowsim.tmp";
  std::error_code ec;
  for (int i = 0; i < 1000; ++i) {  // between two checkpoints' writes
    fs::create_symlink("/dev/full", temporary, ec);
    if (!ec) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_FALSE(ec) << ec.message();
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_FALSE(fs::exists(fs::symlink_status(temporary))) << "the failed temporary is removed";
  const auto resumed = runSnowsim("resume " + out.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(frames(out), frames(whole));
}

// A second signal stops at once: exit 128 + signal, no temporary or partial file left behind.
THREADED_TEST(Checkpoint, ASecondSignalStopsAtOnceLeavingOnlyCompleteFiles) {
  const fs::path out = freshDir("second_signal");
  std::vector<std::string> args = runArgs(kCases[2], out, 1);
  std::erase(args, std::string("--no-mp4"));
  args.insert(args.end(), {"--set", "time.duration=100"});
  const pid_t child = startSnowsim(args);
  ASSERT_TRUE(waitFor(out / frameName(1, "png")));
  kill(child, SIGINT);
  const int status = finish(child, SIGINT);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGINT);
  for (const auto& entry : fs::directory_iterator(out)) {
    const std::string name = entry.path().filename().string();
    EXPECT_FALSE(name.ends_with(".tmp") || name.ends_with(".part")) << name;
  }
}
