#include "scene_text.hpp"

#include "voxpack/core/errors.hpp"

namespace voxpack::app {

void rejectNonAsciiOutsideStrings(const std::string& t, const std::string& name) {
  // A scene's keys, numbers and shape specs are ASCII; file paths in strings and comments
  // may be anything. Multi-line strings are refused too: the parser classifies the first
  // character after a line-ending backslash there (issue 190).
  enum class In { Plain, Comment, Basic, Literal, MultiBasic, MultiLiteral };
  In in = In::Plain;
  int line = 1;
  auto refuse = [&](const char* where) {
    throw InputError(name + ":" + std::to_string(line) + ": a non-ASCII character " + where +
                     " (scene files are ASCII outside strings and comments)");
  };
  for (std::size_t i = 0; i < t.size(); ++i) {
    const auto c = static_cast<unsigned char>(t[i]);
    if (c == '\n') {
      ++line;
      if (in == In::Comment || in == In::Basic || in == In::Literal) in = In::Plain;
      continue;
    }
    switch (in) {
      case In::Plain:
        if (c >= 0x80) refuse("outside a string or comment");
        if (c == '#') {
          in = In::Comment;
        } else if (t.compare(i, 3, "\"\"\"") == 0) {
          in = In::MultiBasic;
          i += 2;
        } else if (t.compare(i, 3, "'''") == 0) {
          in = In::MultiLiteral;
          i += 2;
        } else if (c == '"') {
          in = In::Basic;
        } else if (c == '\'') {
          in = In::Literal;
        }
        break;
      case In::Comment:
        break;
      case In::Basic:
        if (c == '\\' && i + 1 < t.size() && t[i + 1] != '\n')
          ++i;  // an escaped character
        else if (c == '"')
          in = In::Plain;
        break;
      case In::Literal:
        if (c == '\'') in = In::Plain;
        break;
      case In::MultiBasic:
      case In::MultiLiteral:
        if (c >= 0x80) refuse("in a multi-line string");
        if (in == In::MultiBasic && c == '\\' && i + 1 < t.size() && t[i + 1] != '\n') {
          ++i;
        } else if (t.compare(i, 3, in == In::MultiBasic ? "\"\"\"" : "'''") == 0) {
          in = In::Plain;
          i += 2;
        }
        break;
    }
  }
}

}  // namespace voxpack::app
