// What a valid configuration may still get wrong, said at start-up and by --check-config.
#pragma once

#include <string>
#include <vector>

#include "palletd/config/config.hpp"

namespace palletd {

/// Warnings about a valid configuration, one sentence each: recipes holding formats whose cartons
/// a layer cannot tell apart by their size (look_alike_formats(), with the cartons' oversize of
/// detection.layout.refine.max_oversize and gaps of up to 20 mm).
std::vector<std::string> config_warnings(const Config& config);

}  // namespace palletd
