// Stages 3-4: layer mask in image space, border pixels, components and holes (OpenCV).
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {

cv::Mat border_of(const cv::Mat& mask) {
  cv::Mat eroded;
  // A layer pixel is interior when all 8 neighbours are layer; outside the image counts as off.
  cv::erode(mask, eroded, cv::Mat::ones(3, 3, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_CONSTANT,
            cv::Scalar(0));
  cv::Mat border;
  cv::subtract(mask, eroded, border);
  return border;
}

LayerMask layer_mask(const OrganizedCloud& cloud, const Plane& plane, const BandTable& band,
                     const PlaneParams& validity) {
  LayerMask out;
  const int w = cloud.width, h = cloud.height;
  cv::Mat raw(h, w, CV_8U, cv::Scalar(0));
  // Fill candidates: pixels off the layer that are invalid or a noise outlier near the plane
  // (within twice the band; further off is a real surface, e.g. seen through a gap), not on the
  // image frame (they have too few neighbours to be filled).
  std::vector<int> candidates;
  // Loop invariants as locals: the stores into the mask are byte stores, which the compiler must
  // assume may change anything it would otherwise keep in registers.
  const Eigen::Vector3f n = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  const BandTable local_band = band;
  const PlaneParams local_validity = validity;
  std::size_t raw_pixels = 0;
  for (int v = 0; v < h; ++v) {
    auto* row = raw.ptr<std::uint8_t>(v);
    const Eigen::Vector3f* points = &cloud.at(0, v);
    const bool inner_row = v > 0 && v + 1 < h;
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3f& p = points[u];
      const bool candidate = inner_row && u > 0 && u + 1 < w;
      if (!usable(p, local_validity)) {
        if (candidate) candidates.push_back(v * w + u);
        continue;
      }
      const float s = std::abs(n.dot(p) + d);
      const float tol = local_band.at(p.z());
      if (s <= tol) {
        row[u] = 255;
        ++raw_pixels;
      } else if (s <= 2.0F * tol && candidate) {
        candidates.push_back(v * w + u);
      }
    }
  }
  out.raw_layer_pixels = raw_pixels;
  // Dropouts and noise outliers (invalid, or within twice the band): such a pixel with at least 7
  // of its 8 neighbours on the layer is layer. Two passes close pairs and small clusters; a one-pixel-wide
  // line (6 neighbours), i.e. a real gap, stays. Only the candidates (off the layer, fillable, inside the
  // image frame: a few percent of the pixels) are visited; each pass decides on the mask as it was before the
  // pass. A pixel the first pass filled had all its neighbours but one on; two filled neighbours of one
  // candidate are never neighbours of each other, so at most its four corners are filled: with
  // fewer than three neighbours on before, it cannot reach seven in the second pass.
  constexpr int kMinOnForLaterPass = 3;
  std::vector<int> fill;
  for (int pass = 0; pass < 2 && !candidates.empty(); ++pass) {
    fill.clear();
    std::size_t keep = 0;
    for (const int i : candidates) {
      const std::uint8_t* c = raw.data + i;
      const int on = (c[-w - 1] != 0) + (c[-w] != 0) + (c[-w + 1] != 0) + (c[-1] != 0) + (c[1] != 0) +
                     (c[w - 1] != 0) + (c[w] != 0) + (c[w + 1] != 0);
      if (on >= 7) fill.push_back(i);
      else if (on >= kMinOnForLaterPass)
        candidates[keep++] = i;
    }
    candidates.resize(keep);
    if (fill.empty()) break;
    out.filled_dropouts += fill.size();
    for (const int i : fill) raw.data[i] = 255;
  }
  // Flying pixels and one-pixel spurs at the edge: a 3x3 opening.
  cv::morphologyEx(raw, out.mask, cv::MORPH_OPEN, cv::Mat::ones(3, 3, CV_8U), cv::Point(-1, -1), 1,
                   cv::BORDER_CONSTANT, cv::Scalar(0));
  if (w > 0 && h > 0) {
    out.touches_image_border = cv::countNonZero(out.mask.row(0)) > 0 ||
                               cv::countNonZero(out.mask.row(h - 1)) > 0 ||
                               cv::countNonZero(out.mask.col(0)) > 0 ||
                               cv::countNonZero(out.mask.col(w - 1)) > 0;
  }
  out.border = border_of(out.mask);
  return out;
}

namespace {

/// Per label of `labels` (CV_32S, n_labels): 1 where the component has a pixel in the image's
/// first or last row or column.
std::vector<char> labels_at_frame(const cv::Mat& labels, int n_labels) {
  std::vector<char> at(static_cast<std::size_t>(std::max(n_labels, 1)), 0);
  auto mark = [&](int u, int v) { at[static_cast<std::size_t>(labels.at<std::int32_t>(v, u))] = 1; };
  for (int u = 0; u < labels.cols; ++u) mark(u, 0), mark(u, labels.rows - 1);
  for (int v = 0; v < labels.rows; ++v) mark(0, v), mark(labels.cols - 1, v);
  return at;
}

/// Per label of `labels` (CV_32S, n_labels): the area its pixels cover on the plane [m^2], each
/// pixel's footprint where its ray meets the plane.
std::vector<double> label_areas_m2(const cv::Mat& labels, int n_labels, const Plane& plane,
                                   const Intrinsics& intrinsics) {
  std::vector<double> area(static_cast<std::size_t>(std::max(n_labels, 1)), 0.0);
  const double dist = std::max(plane.d, 1e-6);
  std::vector<double> ray_x(static_cast<std::size_t>(labels.cols));  // per column
  for (int u = 0; u < labels.cols; ++u)
    ray_x[static_cast<std::size_t>(u)] = (static_cast<double>(u) - intrinsics.cx) / intrinsics.fx;
  for (int v = 0; v < labels.rows; ++v) {
    const auto* lab = labels.ptr<std::int32_t>(v);
    const double ry = (static_cast<double>(v) - intrinsics.cy) / intrinsics.fy;
    for (int u = 0; u < labels.cols; ++u) {
      if (lab[u] <= 0) continue;
      const double rx = ray_x[static_cast<std::size_t>(u)];
      const double denom = -(plane.normal.x() * rx + plane.normal.y() * ry + plane.normal.z());
      const double z = denom > 1e-9 ? dist / denom : 0.0;
      area[static_cast<std::size_t>(lab[u])] += pixel_area_m2(z, dist, intrinsics);
    }
  }
  return area;
}

}  // namespace

Components find_components(cv::Mat& mask, cv::Mat& border, const OrganizedCloud& cloud,
                           const Plane& plane, const Intrinsics& intrinsics, double min_area_m2,
                           int min_hole_area_px) {
  (void)cloud;
  Components out;
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask.clone(), contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);

  cv::Mat labels;
  const int n_labels = cv::connectedComponents(mask, labels, 8, CV_32S);
  const std::vector<double> label_area = label_areas_m2(labels, n_labels, plane, intrinsics);
  const std::vector<char> at_frame = labels_at_frame(labels, n_labels);

  // Ring id and chain position per traced contour pixel (by pixel index; contours are a small
  // share of the image, so no image-sized tables).
  std::unordered_map<int, std::pair<int, int>> traced;
  std::size_t contour_points = 0;
  for (const auto& c : contours) contour_points += c.size();
  traced.reserve(contour_points);
  const int cols = mask.cols;
  struct RingRef {
    std::size_t component;
    int hole;  // -1 = outer
  };
  std::vector<RingRef> refs;
  std::vector<char> label_dropped(label_area.size(), 0);
  auto take_ring = [&](const std::vector<cv::Point>& contour, RingPixels& ring) {
    const int id = static_cast<int>(refs.size()) - 1;
    for (const cv::Point& p : contour) {
      // First visit only.
      if (!traced.emplace(p.y * cols + p.x, std::make_pair(id, static_cast<int>(ring.pixels.size()))).second) continue;
      ring.pixels.push_back(p);
    }
  };
  for (std::size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0) continue;  // holes are visited through their parent
    const int label = labels.at<std::int32_t>(contours[i].front());
    const double area = label > 0 ? label_area[static_cast<std::size_t>(label)] : 0.0;
    if (area < min_area_m2) {
      ++out.dropped;
      if (label > 0) {
        label_dropped[static_cast<std::size_t>(label)] = 1;
        if (at_frame[static_cast<std::size_t>(label)] != 0)
          out.largest_cut_m2 = std::max(out.largest_cut_m2, area);
      }
      continue;
    }
    Component comp;
    comp.area_m2 = area;
    out.kept.push_back(comp);
    refs.push_back({out.kept.size() - 1, -1});
    take_ring(contours[i], out.kept.back().outer);
    for (int c = hierarchy[i][2]; c >= 0; c = hierarchy[static_cast<std::size_t>(c)][0]) {
      const auto& hole = contours[static_cast<std::size_t>(c)];
      if (std::abs(cv::contourArea(hole)) <= static_cast<double>(min_hole_area_px)) {
        // Too small to be a gap between boxes: a cluster of dropouts. Take it as layer.
        cv::drawContours(mask, contours, c, cv::Scalar(255), cv::FILLED);
        continue;
      }
      RingPixels ring;
      ring.hole = true;
      out.kept.back().holes.push_back(ring);
      refs.push_back({out.kept.size() - 1, static_cast<int>(out.kept.back().holes.size()) - 1});
      take_ring(hole, out.kept.back().holes.back());
    }
  }
  // Dropped components leave the mask.
  for (int v = 0; out.dropped > 0 && v < mask.rows; ++v) {
    const auto* lab = labels.ptr<std::int32_t>(v);
    auto* m = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u)
      if (lab[u] > 0 && label_dropped[static_cast<std::size_t>(lab[u])] != 0) m[u] = 0;
  }
  border = border_of(mask);

  // Border pixels the tracer did not visit join the ring of a traced neighbour.
  auto ring_of = [&](std::size_t r) -> RingPixels& {
    Component& comp = out.kept[refs[r].component];
    return refs[r].hole < 0 ? comp.outer : comp.holes[static_cast<std::size_t>(refs[r].hole)];
  };
  for (std::size_t r = 0; r < refs.size(); ++r) ring_of(r).chain.resize(ring_of(r).pixels.size());
  for (std::size_t r = 0; r < refs.size(); ++r) {
    RingPixels& ring = ring_of(r);
    for (std::size_t k = 0; k < ring.chain.size(); ++k) ring.chain[k] = static_cast<int>(k);
  }
  for (int v = 0; v < border.rows; ++v) {
    const auto* b = border.ptr<std::uint8_t>(v);
    for (int u = 0; u < border.cols; ++u) {
      if (b[u] == 0 || traced.count(v * cols + u) != 0) continue;
      for (int k = 0; k < 8; ++k) {
        static const int du[8] = {-1, 1, 0, 0, -1, 1, -1, 1};
        static const int dv[8] = {0, 0, -1, 1, -1, -1, 1, 1};
        const int uu = u + du[k], vv = v + dv[k];
        if (uu < 0 || vv < 0 || uu >= border.cols || vv >= border.rows) continue;
        const auto it = traced.find(vv * cols + uu);
        if (it == traced.end()) continue;
        RingPixels& ring = ring_of(static_cast<std::size_t>(it->second.first));
        ring.pixels.emplace_back(u, v);
        ring.chain.push_back(it->second.second);
        break;
      }
    }
  }
  return out;
}

}  // namespace palletd::layer
