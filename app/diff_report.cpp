#include "app/diff_report.h"

#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace fs = std::filesystem;

namespace {

// printf-style formatting of a few numbers into a string.
template <typename... Args>
std::string format(const char* pattern, Args... args) {
  char text[256];
  std::snprintf(text, sizeof text, pattern, args...);
  return text;
}

std::string figuresText(const DiffFigures& f) {
  return format("%ld of %ld pixels differ (share %.4f = %.2f%%), largest difference %.3f",
                f.differing, f.compared, f.share, 100 * f.share, f.largest);
}

std::string limitsText(const DiffLimits& limits) {
  std::string text = format("--threshold %g, --max-share %g", limits.threshold, limits.max_share);
  if (!limits.mask.empty()) text += ", --mask " + limits.mask;
  if (limits.directories) {
    text += limits.missing_fail ? ", missing frames fail" : ", missing frames allowed";
    text += limits.extra_fail ? ", extra frames fail" : ", extra frames allowed";
  }
  return text;
}

const char* statusName(FrameResult::Status status) {
  switch (status) {
    case FrameResult::Status::Passed:
      return "pass";
    case FrameResult::Status::Failed:
      return "fail";
    case FrameResult::Status::Missing:
      return "missing";
    case FrameResult::Status::Extra:
      return "extra";
    case FrameResult::Status::Resized:
      return "resized";
  }
  return "";
}

long countStatus(const RunComparison& comparison, FrameResult::Status status) {
  return std::count_if(comparison.frames.begin(), comparison.frames.end(),
                       [status](const FrameResult& f) { return f.status == status; });
}

std::string escapeHtml(const std::string& text) {
  std::string out;
  for (const char c : text) switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  return out;
}

// A file name as a relative URL: everything but unreserved characters percent-encoded.
std::string urlPath(const std::string& name) {
  std::string out;
  for (const unsigned char c : name)
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~')
      out += char(c);
    else
      out += format("%%%02X", c);
  return out;
}

// The page's generator tag: how an earlier report is told from a directory of other things.
constexpr const char* kGenerator = "<meta name=\"generator\" content=\"snowsim diff\">";

bool isEarlierReport(const fs::path& dir) {
  std::ifstream index(dir / "index.html");
  std::string head(512, '\0');
  index.read(head.data(), std::streamsize(head.size()));
  return head.find(kGenerator) != std::string::npos;
}

// The report's image folders, with the caption each image gets.
constexpr std::pair<const char*, const char*> kFolders[] = {
    {"a", "A (expected)"}, {"b", "B (actual)"}, {"diff", "diff"}};

}  // namespace

std::string sizeText(const ImageSize& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

bool RunComparison::fails(const FrameResult& frame) const {
  switch (frame.status) {
    case FrameResult::Status::Passed:
      return false;
    case FrameResult::Status::Failed:
    case FrameResult::Status::Resized:
      return true;
    case FrameResult::Status::Missing:
      return limits.missing_fail;
    case FrameResult::Status::Extra:
      return limits.extra_fail;
  }
  return true;
}

bool RunComparison::passed() const {
  return comparedFrames() > 0 && std::none_of(frames.begin(), frames.end(),
                                              [this](const FrameResult& f) { return fails(f); });
}

long RunComparison::comparedFrames() const {
  return std::count_if(frames.begin(), frames.end(), [](const FrameResult& f) {
    return f.status == FrameResult::Status::Passed || f.status == FrameResult::Status::Failed ||
           f.status == FrameResult::Status::Resized;
  });
}

std::string frameLine(const RunComparison& comparison, const FrameResult& frame) {
  const std::string verdict = comparison.fails(frame) ? "FAIL  " : "ok    ";
  switch (frame.status) {
    case FrameResult::Status::Passed:
      if (frame.figures.differing == 0) return "";
      [[fallthrough]];
    case FrameResult::Status::Failed:
      return verdict + frame.name + ": " + figuresText(frame.figures);
    case FrameResult::Status::Missing:
      return verdict + frame.name + ": missing from B (in A only)";
    case FrameResult::Status::Extra:
      return verdict + frame.name + ": extra in B (not in A)";
    case FrameResult::Status::Resized:
      return verdict + frame.name + ": resized: " + sizeText(frame.size_a) + " in A, " +
             sizeText(frame.size_b) + " in B (no pixel compared)";
  }
  return "";
}

std::string summaryLine(const RunComparison& comparison) {
  std::string text = comparison.passed() ? "PASS: " : "FAIL: ";
  if (comparison.limits.directories) {
    const long missing = countStatus(comparison, FrameResult::Status::Missing),
               extra = countStatus(comparison, FrameResult::Status::Extra),
               compared = long(comparison.frames.size()) - missing - extra;
    const long resized = countStatus(comparison, FrameResult::Status::Resized);
    text += format("%ld of %ld frames beyond the limits",
                   countStatus(comparison, FrameResult::Status::Failed) + resized, compared);
    if (resized > 0) text += format(" (%ld of them resized)", resized);
    text += format(", %ld missing from B, %ld extra in B", missing, extra);
    if (compared == 0) text += " (no frame is in both: nothing was compared)";
  } else if (const FrameResult& frame = comparison.frames.front();
             frame.status == FrameResult::Status::Resized) {
    text += "the image size differs (" + sizeText(frame.size_a) + " in A, " +
            sizeText(frame.size_b) + " in B)";
  } else {
    text += format("share %.4f of the pixels differ", frame.figures.share);
  }
  return text + "; limits: " + limitsText(comparison.limits);
}

void checkJsonReportPath(const std::string& path) {
  if (fs::is_directory(path))
    throw InputError("--json " + path + ": is a directory; give the report's file name");
  const std::string probe = path + ".tmp";
  if (!std::ofstream(probe))
    throw InputError("--json " + path + ": cannot write (" + std::strerror(errno) + ")");
  fs::remove(probe);
}

void writeJsonReport(const std::string& path, const RunComparison& comparison) {
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const FrameResult& frame : comparison.frames) {
    const DiffFigures& f = frame.figures;
    nlohmann::ordered_json entry = {{"name", frame.name}, {"status", statusName(frame.status)}};
    if (frame.status == FrameResult::Status::Passed || frame.status == FrameResult::Status::Failed)
      entry.update({{"compared_pixels", f.compared},
                    {"differing_pixels", f.differing},
                    {"anti_aliased_pixels", f.anti_aliased},
                    {"share", f.share},
                    {"largest_difference", f.largest}});
    if (frame.status == FrameResult::Status::Resized)
      entry.update({{"size_a", {frame.size_a.width, frame.size_a.height}},
                    {"size_b", {frame.size_b.width, frame.size_b.height}}});
    frames.push_back(entry);
  }
  const DiffLimits& limits = comparison.limits;
  nlohmann::ordered_json report = {
      {"result", comparison.passed() ? "PASS" : "FAIL"},
      {"a", comparison.a},
      {"b", comparison.b},
      {"limits",
       {{"threshold", limits.threshold},
        {"max_share", limits.max_share},
        {"mask",
         limits.mask.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(limits.mask)}}},
      {"frames", frames}};
  if (limits.directories) {
    report["limits"]["missing_frames_fail"] = limits.missing_fail;
    report["limits"]["extra_frames_fail"] = limits.extra_fail;
  }
  writeFileAtomically(path, report.dump(2) + "\n");
}

HtmlReport::HtmlReport(const std::string& dir)
    : name_(dir), dir_(fs::weakly_canonical(fs::absolute(dir))) {
  if (!dir_.has_filename() && dir_.has_relative_path()) dir_ = dir_.parent_path();  // "report/"
  const auto refuse = [&](const std::string& why) {
    throw InputError("--html " + name_ + ": " + why);
  };
  if (!dir_.has_filename()) refuse("give a directory of its own for the report");
  std::error_code ec;
  if (fs::exists(dir_) &&
      !(fs::is_directory(dir_) && (fs::is_empty(dir_) || isEarlierReport(dir_))))
    refuse("exists and is not an earlier report of snowsim diff; give a new or empty directory");
  fs::create_directories(dir_.parent_path(), ec);
  std::string pattern = (dir_.parent_path() / (dir_.filename().string() + ".tmp-XXXXXX")).string();
  if (ec || !mkdtemp(pattern.data()))
    refuse("cannot create the report directory (" + (ec ? ec.message() : std::strerror(errno)) +
           ")");
  // mkdtemp makes the directory private; a report is for sharing.
  fs::permissions(pattern,
                  fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                      fs::perms::others_read | fs::perms::others_exec,
                  ec);
  for (const auto& [folder, caption] : kFolders)
    if (!ec) fs::create_directory(fs::path(pattern) / folder, ec);
  if (ec) {
    fs::remove_all(pattern);
    refuse("cannot create the report directory (" + ec.message() + ")");
  }
  building_ = pattern;
}

HtmlReport::~HtmlReport() {
  std::error_code ec;
  if (!building_.empty()) fs::remove_all(building_, ec);
}

void HtmlReport::addFailingFrame(const std::string& name, const fs::path& a, const fs::path& b,
                                 const Image& diff) {
  addResizedFrame(name, a, b);
  writePng((building_ / "diff" / name).string(), diff);
}

void HtmlReport::addResizedFrame(const std::string& name, const fs::path& a, const fs::path& b) {
  std::error_code ec;
  for (const auto& [from, folder] : {std::pair{a, "a"}, std::pair{b, "b"}})
    if (!fs::copy_file(from, building_ / folder / name, ec))
      throw InputError("--html " + name_ + ": cannot copy " + from.string() + " (" + ec.message() +
                       ")");
}

void HtmlReport::finish(const RunComparison& comparison) {
  const bool passed = comparison.passed();
  std::string page =
      std::string("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n") +
      kGenerator + "\n<title>snowsim diff: " + (passed ? "PASS" : "FAIL") +
      "</title>\n<style>\n"
      "body { font-family: sans-serif; margin: 1.5em; }\n"
      ".pass { color: #1a7f37; } .fail { color: #cf222e; }\n"
      ".row { display: flex; gap: 1em; flex-wrap: wrap; }\n"
      "figure { margin: 0; } figcaption { font-size: 0.9em; color: #555; }\n"
      "img { width: 31vw; border: 1px solid #ccc; }\n"
      "</style>\n</head>\n<body>\n";
  page += "<h1 class=\"" + std::string(passed ? "pass" : "fail") + "\">" +
          escapeHtml(summaryLine(comparison)) + "</h1>\n";
  page += "<p>A: <code>" + escapeHtml(comparison.a) + "</code><br>B: <code>" +
          escapeHtml(comparison.b) + "</code></p>\n";
  page +=
      "<p>Diff images: red pixels differ beyond the threshold, yellow ones differ on an "
      "anti-aliased edge and are not counted, light blue ones are masked out, the rest is A "
      "faded.</p>\n";
  std::string missing_or_extra;
  for (const FrameResult& frame : comparison.frames) {
    if (frame.status == FrameResult::Status::Missing ||
        frame.status == FrameResult::Status::Extra) {
      missing_or_extra += "<li>" + escapeHtml(frameLine(comparison, frame)) + "</li>\n";
      continue;
    }
    const bool resized = frame.status == FrameResult::Status::Resized;
    if (frame.status != FrameResult::Status::Failed && !resized) continue;
    const std::string url = urlPath(frame.name);
    page += "<h2>" + escapeHtml(frameLine(comparison, frame)) + "</h2>\n<div class=\"row\">\n";
    for (const auto& [folder, caption] : kFolders)
      if (!resized || std::string(folder) != "diff")
        page += std::string("<figure><a href=\"") + folder + "/" + url + "\"><img src=\"" + folder +
                "/" + url + "\" alt=\"" + caption + "\"></a><figcaption>" + caption +
                "</figcaption></figure>\n";
    page += "</div>\n";
  }
  if (!missing_or_extra.empty())
    page += "<h2>Missing and extra frames</h2>\n<ul>\n" + missing_or_extra + "</ul>\n";
  page += "</body>\n</html>\n";
  writeFileAtomically((building_ / "index.html").string(), page);

  // An earlier report is replaced whole; there is a moment with none, never one half-written.
  std::error_code ec;
  fs::remove_all(dir_, ec);
  fs::rename(building_, dir_, ec);
  if (ec)
    throw InputError("--html " + name_ + ": cannot move the report into place (" + ec.message() +
                     ")");
  building_.clear();
}

}  // namespace snowsim
