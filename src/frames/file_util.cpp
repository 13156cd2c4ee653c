#include "palletd/frames/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace palletd::io_detail {

namespace fs = std::filesystem;

Expected<std::string> read_text_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error{path + ": file not found"};
  if (fs::is_directory(path, ec)) return Error{path + ": is a directory, not a file"};
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot open: " + std::strerror(errno)};
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Error{path + ": read error"};
  return text.str();
}

namespace {

/// Owns a POSIX file descriptor.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  [[nodiscard]] int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }

 private:
  int fd_;
};

}  // namespace

Status write_file_atomically(const std::string& path, const std::string& data) {
  const fs::path target(path);
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string temp = (folder / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  Fd fd(::mkstemp(temp.data()));
  if (fd.get() < 0) return Error{path + ": cannot create a temporary file: " + std::strerror(errno)};
  const char* p = data.data();
  std::size_t left = data.size();
  while (left > 0) {
    const ssize_t n = ::write(fd.get(), p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string reason = std::strerror(errno);
      ::unlink(temp.c_str());
      return Error{path + ": write failed: " + reason};
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  // mkstemp creates 0600; recorded frames are meant to be read by others too.
  ::fchmod(fd.get(), 0644);
  if (::fsync(fd.get()) != 0 || ::close(fd.release()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temp.c_str());
    return Error{path + ": write failed: " + reason};
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temp.c_str());
    return Error{path + ": cannot rename the temporary file into place: " + reason};
  }
  return {};
}

Expected<nlohmann::json> parse_json_file(const std::string& path) {
  auto text = read_text_file(path);
  if (!text) return Error{text.error()};
  try {
    return nlohmann::json::parse(*text);
  } catch (const nlohmann::json::parse_error& e) {
    return Error{path + ": not valid JSON (byte " + std::to_string(e.byte) + ")"};
  } catch (const nlohmann::json::exception& e) {  // e.g. out_of_range.406: a number beyond double
    return Error{path + ": not valid JSON (" + e.what() + ")"};
  }
}

std::string get_number(const nlohmann::json& object, const char* key, double& out) {
  const auto it = object.find(key);
  if (it == object.end()) return std::string("missing key '") + key + "'";
  if (!it->is_number()) return std::string("key '") + key + "' must be a number";
  out = it->get<double>();
  if (!std::isfinite(out)) return std::string("key '") + key + "' must be finite";
  return {};
}

std::string get_integer(const nlohmann::json& object, const char* key, long long& out) {
  const auto it = object.find(key);
  if (it == object.end()) return std::string("missing key '") + key + "'";
  if (it->is_number_unsigned()) {
    const auto u = it->get<unsigned long long>();
    if (u > static_cast<unsigned long long>(std::numeric_limits<long long>::max()))
      return std::string("key '") + key + "' is out of range";
    out = static_cast<long long>(u);
    return {};
  }
  if (!it->is_number_integer()) return std::string("key '") + key + "' must be an integer";
  out = it->get<long long>();
  return {};
}

std::string get_string(const nlohmann::json& object, const char* key, std::string& out) {
  const auto it = object.find(key);
  if (it == object.end()) return std::string("missing key '") + key + "'";
  if (!it->is_string()) return std::string("key '") + key + "' must be a string";
  out = it->get<std::string>();
  return {};
}

std::string get_numbers(const nlohmann::json& value, const std::string& what, std::size_t count,
                        double* out) {
  if (!value.is_array() || value.size() != count)
    return what + " must be an array of " + std::to_string(count) + " numbers";
  for (std::size_t i = 0; i < count; ++i) {
    if (!value[i].is_number()) return what + " must be an array of " + std::to_string(count) + " numbers";
    out[i] = value[i].get<double>();
    if (!std::isfinite(out[i])) return what + " must contain finite numbers";
  }
  return {};
}

}  // namespace palletd::io_detail
