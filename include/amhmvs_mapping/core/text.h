// Small text helpers shared by the readers of key/value files.
#pragma once

#include <string>

namespace amhmvs {

// `text` without leading and trailing spaces, tabs and carriage returns.
inline std::string trimmed(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

}  // namespace amhmvs
