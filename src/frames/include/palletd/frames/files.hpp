// palletd io, private: small file helpers shared by the frame, truth and JSON code.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "palletd/core/expected.hpp"

namespace palletd::io_detail {

/// Reads a whole file; the error names the file.
Expected<std::string> read_text_file(const std::string& path);

/// Writes `data` to a temporary file in the same folder and renames it over `path`, so readers
/// see either the old file or the complete new one, never half of it.
Status write_file_atomically(const std::string& path, const std::string& data);

/// Parses a JSON document; the error names the file and the position.
Expected<nlohmann::json> parse_json_file(const std::string& path);

/// Typed access to JSON object members. Each returns an error sentence (empty when fine) that
/// the caller prefixes with the file name.
std::string get_number(const nlohmann::json& object, const char* key, double& out);
std::string get_integer(const nlohmann::json& object, const char* key, long long& out);
std::string get_string(const nlohmann::json& object, const char* key, std::string& out);
/// A JSON array of exactly `count` finite numbers.
std::string get_numbers(const nlohmann::json& value, const std::string& what, std::size_t count,
                        double* out);

}  // namespace palletd::io_detail
