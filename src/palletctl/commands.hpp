// palletctl subcommands. Each lives in cmd_<name>.cpp and adds itself to the app with
// register_<name>(app); main.cpp calls every register function once. A subcommand writes data to
// stdout, logs through spdlog (stderr), and reports failure by throwing CLI::RuntimeError(code).
#pragma once

#include <CLI/CLI.hpp>

#include "palletd/config/config.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

void register_frame_info(CLI::App& app);  // palletctl info STEM...
void register_watch(CLI::App& app);       // palletctl watch --host H: the status block live
void register_calibrate(CLI::App& app);   // palletctl calibrate --frame STEM --points FILE
void register_trigger(CLI::App& app);     // palletctl trigger --host H
void register_detect(CLI::App& app);      // palletctl detect --box LxW STEM...
void register_eval(CLI::App& app);        // palletctl eval DIR
void register_simulate(CLI::App& app);    // palletctl simulate --out DIR -n N (scene simulator)
void register_roi(CLI::App& app);         // palletctl roi STEM: suggest detection.roi from a frame
void register_compare(CLI::App& app);     // palletctl compare --config A --config B DIR
void register_drift(CLI::App& app);       // palletctl drift --config F [--set] [STEM...]
void register_teach(CLI::App& app);       // palletctl teach STEM: carton sizes measured, as config entries

void register_grab(CLI::App& app);    // palletctl grab --config FILE -n N --out DIR
void register_record(CLI::App& app);  // palletctl record --config FILE [--out DIR]

/// `camera_to_base: [...]` as the configuration reads it (4x4 row-major, metres), one line
/// (cmd_calibrate.cpp; `palletctl roi` prints it beside a base-frame region).
std::string camera_to_base_yaml(const Eigen::Isometry3d& T_base_camera);

/// One frame from the configured camera (opened and closed for it), with the configuration's
/// camera_to_base (cmd_grab.cpp; `drift --set` uses it).
Expected<Frame> grab_one_frame(const Config& config);

}  // namespace palletd
