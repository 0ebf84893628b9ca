#pragma once

// Documented limits on inputs (docs/file-formats.md, "Limits") and the memory budget that every
// command checks before it allocates. std-only so that every module can use it.

#include <cstddef>
#include <string>

#include "gonio/base/error.h"

namespace gonio {

/// Largest JSON input file read (model, fit template, campaign, rig, scene, metadata).
constexpr std::size_t kMaxJsonBytes = 16u << 20;
/// Deepest nesting of objects and arrays in a JSON input.
constexpr int kMaxJsonDepth = 64;
/// Longest string value in a JSON input (names, paths, notes).
constexpr std::size_t kMaxJsonString = 4096;
/// Most lobes of a model.
constexpr std::size_t kMaxModelLobes = 16;
/// Default memory budget of one command (2 GiB), overridable with --max-memory.
constexpr std::size_t kDefaultMaxMemoryBytes = std::size_t{2} << 30;

/// The process-wide memory budget (kDefaultMaxMemoryBytes until set_max_memory_bytes()).
std::size_t max_memory_bytes();
void set_max_memory_bytes(std::size_t bytes);

/// "1.5 GiB", "512 MiB", "12 KiB", "17 B".
std::string human_bytes(double bytes);

/// Six significant digits ("1e+308", "0.25", "-3"): never hundreds of digits.
std::string show_number(double v);

/// "4G", "512M", "100k", "1000000" (bytes; k/M/G/T are powers of 1024, optional "iB"/"B").
Expected<std::size_t> parse_byte_size(const std::string& text);

/// Refuses work that needs more than max_memory_bytes(): "WHAT needs 1.5 TiB, above the memory
/// limit of 2 GiB (raise it with --max-memory)". `bytes` is a double so that products of
/// user-given sizes cannot wrap around.
Expected<void> check_memory(double bytes, const std::string& what);

/// Checks the raw text of a JSON document before it is parsed: its size (kMaxJsonBytes) and the
/// nesting depth of its objects and arrays (kMaxJsonDepth), so that no parser, copy or destructor
/// recurses without bound. `source` names the file in the message.
Expected<void> check_json_text(const std::string& text, const std::string& source);

/// Reads a whole input file of at most `max_bytes`, refusing folders, devices and FIFOs with a
/// message naming the file.
Expected<std::string> read_input_file(const std::string& path, std::size_t max_bytes);

}  // namespace gonio
