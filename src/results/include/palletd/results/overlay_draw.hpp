// palletd results: the drawing pieces of the overlay (overlay.hpp), for other pictures over the
// depth image (`palletctl roi --out`). OpenCV types: include it only where OpenCV is linked.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"

namespace palletd {

/// The factor small frames are scaled up by in overlays (1 from 500 px wide up).
double overlay_scale(const Intrinsics& intrinsics);

/// The frame's depth in a colour map (near bright), invalid pixels black; not scaled.
cv::Mat colour_depth_image(const Frame& frame);

/// The overlay pixel (scaled by `scale`) of a camera-frame point in front of the camera.
cv::Point2d project_to_overlay(const Intrinsics& intrinsics, const Eigen::Vector3d& p_camera, double scale);

/// The region's twelve edges in yellow, where both ends lie in front of the camera; nothing for a
/// base-frame region on a frame without T_base_camera.
void draw_region_edges(cv::Mat& image, const Frame& frame, const RegionOfInterest& roi, double scale);

}  // namespace palletd
