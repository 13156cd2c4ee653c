// The recorded frame format (shared/spec/frames.md): STEM.depth.png, STEM.json, STEM.intensity.png.
#include "palletd/frames/frame_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "palletd/frames/files.hpp"

namespace palletd {

namespace fs = std::filesystem;
using io_detail::get_integer;
using io_detail::get_number;
using io_detail::get_numbers;
using io_detail::get_string;

namespace {

const char* const kIntensitySuffix = ".intensity.png";
const char* const kMetaSuffix = ".json";

/// What the PNG header (IHDR) says, read before decoding so errors can be precise.
struct PngHeader {
  int width = 0;
  int height = 0;
  int bit_depth = 0;
  int colour_type = 0;  ///< 0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA
};

std::uint32_t read_be32(const std::string& bytes, std::size_t at) {
  const auto b = [&](std::size_t i) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + i])); };
  return (b(0) << 24U) | (b(1) << 16U) | (b(2) << 8U) | b(3);
}

Expected<PngHeader> parse_png_header(const std::string& path, const std::string& bytes) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (bytes.size() < 8 || !std::equal(kSignature, kSignature + 8, bytes.begin(),
                                      [](unsigned char a, char b) { return a == static_cast<unsigned char>(b); }))
    return Error{path + ": not a PNG file"};
  if (bytes.size() < 33) return Error{path + ": truncated PNG (no complete header)"};
  if (bytes.compare(12, 4, "IHDR") != 0) return Error{path + ": corrupt PNG (first chunk is not IHDR)"};
  PngHeader header;
  const std::uint32_t w = read_be32(bytes, 16);
  const std::uint32_t h = read_be32(bytes, 20);
  if (w == 0 || h == 0 || w > 100000 || h > 100000)
    return Error{path + ": corrupt PNG (image size " + std::to_string(w) + "x" + std::to_string(h) + ")"};
  header.width = static_cast<int>(w);
  header.height = static_cast<int>(h);
  header.bit_depth = static_cast<unsigned char>(bytes[24]);
  header.colour_type = static_cast<unsigned char>(bytes[25]);
  return header;
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

/// Decodes a single-channel PNG of the given bit depth straight into `out` (no extra copy).
Status decode_grey_png(const std::string& path, const std::string& bytes, int bits,
                       std::vector<std::uint16_t>& out, int width, int height) {
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
              const_cast<char*>(bytes.data()));  // imdecode only reads the buffer
  if (bits == 16) {
    out.resize(n);
    cv::Mat dst(height, width, CV_16UC1, out.data());
    const std::uint16_t* const target = out.data();
    cv::imdecode(raw, cv::IMREAD_UNCHANGED, &dst);
    if (dst.empty()) return Error{path + ": cannot decode PNG (truncated or corrupt)"};
    if (dst.type() != CV_16UC1 || dst.rows != height || dst.cols != width)
      return Error{path + ": PNG decoded to an unexpected image type"};
    if (reinterpret_cast<const std::uint16_t*>(dst.data) != target)
      std::copy_n(dst.ptr<std::uint16_t>(), n, out.begin());
    return {};
  }
  cv::Mat dst;
  cv::imdecode(raw, cv::IMREAD_UNCHANGED, &dst);
  if (dst.empty()) return Error{path + ": cannot decode PNG (truncated or corrupt)"};
  if (dst.type() != CV_8UC1 || dst.rows != height || dst.cols != width)
    return Error{path + ": PNG decoded to an unexpected image type"};
  out.resize(n);
  const std::uint8_t* src = dst.ptr<std::uint8_t>();
  std::copy(src, src + n, out.begin());
  return {};
}

Status read_metadata(const std::string& path, Frame& frame) {
  auto doc = io_detail::parse_json_file(path);
  if (!doc) return Error{doc.error()};
  const nlohmann::json& j = *doc;
  if (!j.is_object()) return Error{path + ": must contain a JSON object"};
  const auto fail = [&](const std::string& problem) { return Status(Error{path + ": " + problem}); };

  long long width = 0;
  long long height = 0;
  for (auto [key, value] : {std::pair<const char*, long long*>{"width", &width}, {"height", &height}}) {
    if (auto e = get_integer(j, key, *value); !e.empty()) return fail(e);
    if (*value <= 0 || *value > 100000) return fail(std::string("key '") + key + "' must be positive");
  }
  Intrinsics& k = frame.intrinsics;
  k.width = static_cast<int>(width);
  k.height = static_cast<int>(height);
  for (auto [key, value] : {std::pair<const char*, double*>{"fx", &k.fx}, {"fy", &k.fy}, {"cx", &k.cx},
                            {"cy", &k.cy}, {"depth_scale", &frame.depth_scale_m}}) {
    if (auto e = get_number(j, key, *value); !e.empty()) return fail(e);
  }
  if (k.fx <= 0.0) return fail("focal length 'fx' must be positive");
  if (k.fy <= 0.0) return fail("focal length 'fy' must be positive");
  if (frame.depth_scale_m <= 0.0) return fail("'depth_scale' must be positive");

  frame.camera_id.clear();
  if (j.contains("camera")) {
    if (auto e = get_string(j, "camera", frame.camera_id); !e.empty()) return fail(e);
  }
  frame.timestamp_ns = 0;
  if (j.contains("timestamp_ns")) {
    long long t = 0;
    if (auto e = get_integer(j, "timestamp_ns", t); !e.empty()) return fail(e);
    frame.timestamp_ns = t;
  }
  k.distortion.reset();
  if (const auto it = j.find("distortion"); it != j.end() && !it->is_null()) {
    std::array<double, 5> d{};
    if (auto e = get_numbers(*it, "'distortion'", 5, d.data()); !e.empty()) return fail(e);
    if (std::any_of(d.begin(), d.end(), [](double c) { return c != 0.0; })) k.distortion = d;
  }
  frame.T_base_camera.reset();
  if (const auto it = j.find("camera_to_base"); it != j.end() && !it->is_null()) {
    double m[16];
    if (auto e = get_numbers(*it, "'camera_to_base'", 16, m); !e.empty()) return fail(e);
    Eigen::Matrix4d t;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) t(r, c) = m[r * 4 + c];
    const Eigen::Matrix3d rot = t.topLeftCorner<3, 3>();
    const bool last_row = t(3, 0) == 0.0 && t(3, 1) == 0.0 && t(3, 2) == 0.0 && t(3, 3) == 1.0;
    const double orthonormal_error = (rot.transpose() * rot - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (!last_row || orthonormal_error > 1e-3 || rot.determinant() < 0.0)
      return fail("'camera_to_base' is not a rigid transform (rotation must be orthonormal with "
                  "determinant +1, last row 0 0 0 1)");
    Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
    iso.matrix() = t;
    frame.T_base_camera = iso;
  }
  return {};
}

}  // namespace

Expected<Frame> read_frame(const std::string& stem) {
  Frame frame;
  const std::string meta_path = stem + kMetaSuffix;
  const std::string depth_path = stem + kDepthFileSuffix;
  const std::string intensity_path = stem + kIntensitySuffix;

  if (auto status = read_metadata(meta_path, frame); !status) return Error{status.error()};

  auto depth_bytes = io_detail::read_text_file(depth_path);
  if (!depth_bytes) return Error{depth_bytes.error()};
  auto depth_header = parse_png_header(depth_path, *depth_bytes);
  if (!depth_header) return Error{depth_header.error()};
  if (depth_header->colour_type != 0)
    return Error{depth_path + ": depth PNG must be single-channel (greyscale), this one has colour"};
  if (depth_header->bit_depth != 16)
    return Error{depth_path + ": depth PNG must be 16-bit, this one is " + std::to_string(depth_header->bit_depth) +
                 "-bit"};
  const int width = frame.intrinsics.width;
  const int height = frame.intrinsics.height;
  if (depth_header->width != width || depth_header->height != height)
    return Error{depth_path + ": image size " + size_text(depth_header->width, depth_header->height) +
                 " does not match " + meta_path + " (" + size_text(width, height) + ")"};
  if (auto s = decode_grey_png(depth_path, *depth_bytes, 16, frame.depth, width, height); !s)
    return Error{s.error()};

  std::error_code ec;
  frame.intensity.clear();
  frame.intensity_bits = 0;
  if (fs::exists(intensity_path, ec)) {
    auto bytes = io_detail::read_text_file(intensity_path);
    if (!bytes) return Error{bytes.error()};
    auto header = parse_png_header(intensity_path, *bytes);
    if (!header) return Error{header.error()};
    if (header->colour_type != 0)
      return Error{intensity_path + ": intensity PNG must be single-channel (greyscale), this one has colour"};
    if (header->bit_depth != 8 && header->bit_depth != 16)
      return Error{intensity_path + ": intensity PNG must be 8- or 16-bit, this one is " +
                   std::to_string(header->bit_depth) + "-bit"};
    if (header->width != width || header->height != height)
      return Error{intensity_path + ": image size " + size_text(header->width, header->height) +
                   " does not match the depth image (" + size_text(width, height) + ")"};
    if (auto s = decode_grey_png(intensity_path, *bytes, header->bit_depth, frame.intensity, width, height); !s)
      return Error{s.error()};
    frame.intensity_bits = header->bit_depth;
  }
  return frame;
}

namespace {

Status write_png(const std::string& path, const cv::Mat& image) {
  std::vector<std::uint8_t> encoded;
  try {
    if (!cv::imencode(".png", image, encoded)) return Error{path + ": PNG encoding failed"};
  } catch (const cv::Exception& e) {
    return Error{path + ": PNG encoding failed: " + e.what()};
  }
  return io_detail::write_file_atomically(path, std::string(encoded.begin(), encoded.end()));
}

std::string metadata_json(const Frame& frame) {
  const Intrinsics& k = frame.intrinsics;
  nlohmann::ordered_json j;
  j["width"] = k.width;
  j["height"] = k.height;
  j["fx"] = k.fx;
  j["fy"] = k.fy;
  j["cx"] = k.cx;
  j["cy"] = k.cy;
  j["depth_scale"] = frame.depth_scale_m;
  j["camera"] = frame.camera_id;
  j["timestamp_ns"] = frame.timestamp_ns;
  if (k.distortion) j["distortion"] = *k.distortion;
  if (frame.T_base_camera) {
    const Eigen::Matrix4d& t = frame.T_base_camera->matrix();
    nlohmann::json m = nlohmann::json::array();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m.push_back(t(r, c));
    j["camera_to_base"] = std::move(m);
  }
  return j.dump(2) + "\n";
}

}  // namespace

Status write_frame(const std::string& stem, const Frame& frame) {
  const Intrinsics& k = frame.intrinsics;
  const std::string where = stem + kDepthFileSuffix;
  if (!k.valid()) return Error{where + ": cannot write a frame with invalid intrinsics"};
  if (!(frame.depth_scale_m > 0.0)) return Error{where + ": cannot write a frame with non-positive depth_scale"};
  if (frame.depth.size() != frame.pixel_count())
    return Error{where + ": depth has " + std::to_string(frame.depth.size()) + " pixels, intrinsics say " +
                 size_text(k.width, k.height)};
  if (frame.has_intensity()) {
    if (frame.intensity.size() != frame.pixel_count())
      return Error{stem + kIntensitySuffix + ": intensity has " + std::to_string(frame.intensity.size()) +
                   " pixels, intrinsics say " + size_text(k.width, k.height)};
    if (frame.intensity_bits != 8 && frame.intensity_bits != 16)
      return Error{stem + kIntensitySuffix + ": intensity_bits must be 8 or 16"};
  }

  // Intensity and metadata first, the depth image last: a stem is listed (list_frame_stems) only
  // once its depth image exists, and then the rest is already in place.
  const std::string intensity_path = stem + kIntensitySuffix;
  if (frame.has_intensity()) {
    Status s;
    if (frame.intensity_bits == 16) {
      const cv::Mat image(k.height, k.width, CV_16UC1, const_cast<std::uint16_t*>(frame.intensity.data()));
      s = write_png(intensity_path, image);
    } else {
      cv::Mat image(k.height, k.width, CV_8UC1);
      auto* dst = image.ptr<std::uint8_t>();
      for (std::size_t i = 0; i < frame.intensity.size(); ++i) {
        if (frame.intensity[i] > 255)
          return Error{intensity_path + ": 8-bit intensity holds a value above 255"};
        dst[i] = static_cast<std::uint8_t>(frame.intensity[i]);
      }
      s = write_png(intensity_path, image);
    }
    if (!s) return s;
  } else {
    std::error_code ec;
    fs::remove(intensity_path, ec);  // a stale intensity image would not belong to this frame
  }
  if (auto s = io_detail::write_file_atomically(stem + kMetaSuffix, metadata_json(frame)); !s) return s;
  const cv::Mat depth(k.height, k.width, CV_16UC1, const_cast<std::uint16_t*>(frame.depth.data()));
  return write_png(where, depth);
}

Expected<std::vector<std::string>> list_frame_stems(const std::string& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return Error{directory + ": not a folder (or it does not exist)"};
  std::vector<std::string> stems;
  const std::string suffix = kDepthFileSuffix;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= suffix.size() || name.front() == '.') continue;
    if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) continue;
    if (!it->is_regular_file(ec)) continue;
    stems.push_back((fs::path(directory) / name.substr(0, name.size() - suffix.size())).string());
  }
  if (ec) return Error{directory + ": cannot list: " + ec.message()};
  std::sort(stems.begin(), stems.end());
  return stems;
}

}  // namespace palletd
