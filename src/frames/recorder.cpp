#include "palletd/frames/recorder.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <utility>

#include "palletd/frames/frame_io.hpp"

namespace palletd {

namespace fs = std::filesystem;

namespace {

constexpr const char* kPartialDir = ".partial";

std::string stem_of(const std::string& file_name) {
  const auto dot = file_name.find('.');
  return dot == std::string::npos ? file_name : file_name.substr(0, dot);
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// fsync a file or folder by path; false on failure.
bool sync_path(const fs::path& path, bool directory) {
  const int fd = ::open(path.c_str(), (directory ? O_RDONLY | O_DIRECTORY : O_RDONLY) | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  return ok;
}

Status write_bytes(const fs::path& path, const char* data, std::size_t size) {
  errno = 0;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return Error{"cannot create " + path.string() + (errno ? std::string(": ") + std::strerror(errno) : "")};
  out.write(data, static_cast<std::streamsize>(size));
  out.close();
  if (!out) return Error{"cannot write " + path.string() + (errno ? std::string(": ") + std::strerror(errno) : "")};
  return {};
}

}  // namespace

FrameRecorder::FrameRecorder(RecorderOptions options) : options_(std::move(options)) {}

Status FrameRecorder::scan() {
  entries_.clear();
  total_bytes_ = 0;
  std::error_code ec;
  const fs::path dir(options_.directory);
  fs::create_directories(dir / kPartialDir, ec);
  if (ec) return Error{"recorder: cannot create " + (dir / kPartialDir).string() + ": " + ec.message()};

  // Leftovers of an interrupted write.
  for (const auto& e : fs::directory_iterator(dir / kPartialDir, ec)) fs::remove_all(e.path(), ec);

  struct Group {
    bool has_depth = false;
    std::uint64_t bytes = 0;
    std::vector<fs::path> files;
  };
  std::map<std::string, Group> groups;  // sorted by stem = time order
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string name = e.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    Group& g = groups[stem_of(name)];
    g.has_depth = g.has_depth || ends_with(name, kDepthFileSuffix);
    g.bytes += e.file_size(ec);
    g.files.push_back(e.path());
  }
  if (ec) return Error{"recorder: cannot list " + dir.string() + ": " + ec.message()};
  for (auto& [stem, g] : groups) {
    if (!g.has_depth) {  // renamed halfway when the power went: not a frame
      for (const auto& f : g.files) fs::remove(f, ec);
      continue;
    }
    entries_.push_back(Entry{stem, g.bytes});
    total_bytes_ += g.bytes;
  }
  scanned_ = true;
  prune();
  return {};
}

std::string FrameRecorder::next_stem(const Frame& frame) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d%02d%02dT%02d%02d%02d%03dZ-%06llu", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms),
                static_cast<unsigned long long>(frame.sequence % 1000000));
  std::string stem(buf);
  // Unique even for two frames with one sequence number in one millisecond.
  if (!entries_.empty() && entries_.back().stem.compare(0, stem.size(), stem) == 0) {
    stem += "-" + std::to_string(++counter_);
  }
  return stem;
}

Expected<std::string> FrameRecorder::record(const Frame& frame, const std::string& detection_json,
                                            const std::vector<std::uint8_t>& overlay_png) {
  if (!scanned_) {
    Status s = scan();
    if (!s) return Error{s.error()};
  }
  const fs::path dir(options_.directory);
  const fs::path partial = dir / kPartialDir;
  const std::string stem = next_stem(frame);

  Status written = write_frame((partial / stem).string(), frame);
  if (written && !detection_json.empty()) {
    written = write_bytes(partial / (stem + ".detection.json"), detection_json.data(), detection_json.size());
  }
  if (written && !overlay_png.empty()) {
    written = write_bytes(partial / (stem + ".overlay.png"),
                          reinterpret_cast<const char*>(overlay_png.data()), overlay_png.size());
  }
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(partial, ec)) {
    const std::string name = e.path().filename().string();
    if (stem_of(name) == stem) files.push_back(e.path());
  }
  // On any failure below, nothing of this recording stays (neither in .partial nor renamed).
  const auto discard = [&](const std::string& why) -> Expected<std::string> {
    for (const auto& f : files) {
      fs::remove(f, ec);
      fs::remove(dir / f.filename(), ec);
    }
    return Error{"recorder: " + why};
  };
  if (!written) {
    // Say why when the system knows (a full disk, a read-only one).
    std::string why = written.error();
    const fs::space_info space = fs::space(partial, ec);
    if (!ec && space.available < 64 * 1024) why += " (no space left on " + dir.string() + ")";
    return discard(why);
  }
  // Depth PNG last: the frame becomes visible only when all its files are in place.
  std::stable_partition(files.begin(), files.end(), [](const fs::path& p) {
    return !ends_with(p.filename().string(), kDepthFileSuffix);
  });
  std::uint64_t bytes = 0;
  for (const auto& f : files) {
    bytes += fs::file_size(f, ec);
    if (!sync_path(f, false)) return discard("cannot fsync " + f.string() + ": " + std::strerror(errno));
  }
  for (const auto& f : files) {
    fs::rename(f, dir / f.filename(), ec);
    if (ec) return discard("cannot rename " + f.string() + ": " + ec.message());
  }
  sync_path(dir, true);

  entries_.push_back(Entry{stem, bytes});
  total_bytes_ += bytes;
  prune();
  return (dir / stem).string();
}

void FrameRecorder::prune() {
  const fs::path dir(options_.directory);
  std::error_code ec;
  while (total_bytes_ > options_.max_bytes && entries_.size() > 1) {
    const Entry oldest = entries_.front();
    entries_.pop_front();
    total_bytes_ -= std::min(total_bytes_, oldest.bytes);
    // Depth PNG first so a cut mid-delete leaves no half frame that looks whole.
    fs::remove(dir / (oldest.stem + kDepthFileSuffix), ec);
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      if (stem_of(e.path().filename().string()) == oldest.stem) fs::remove(e.path(), ec);
    }
  }
}

}  // namespace palletd
