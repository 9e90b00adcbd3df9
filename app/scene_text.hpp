#pragma once
// Checks on a scene file's text before toml++ parses it.
#include <string>

namespace voxpack::app {

/// Throws InputError when `text` holds a byte >= 0x80 outside a single-line string or a
/// comment (with `name` and the line). toml++ 3.3, Debian 12's, reaches
/// __builtin_unreachable classifying some non-ASCII code points where it expects
/// whitespace (upstream issues 190 and 295, fixed there in 2026; found here by fuzz_scene).
void rejectNonAsciiOutsideStrings(const std::string& text, const std::string& name);

}  // namespace voxpack::app
