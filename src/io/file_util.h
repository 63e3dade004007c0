// Internal helpers shared by the readers and writers in src/io: whole-file
// reads and writes that report failures as InputError naming the file.
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace internal {

inline std::string readFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file for reading (missing or unreadable)");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path + ": read error");
  return bytes;
}

inline bool isLittleEndianHost() {
  const uint16_t probe = 1;
  return *reinterpret_cast<const uint8_t*>(&probe) == 1;
}

// Whole-token number parsing: false unless the token is entirely a finite
// number (strtod alone would accept "3abc" and "nan").
inline bool parseDouble(const std::string& token, double* value) {
  if (token.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(token.c_str(), &end);
  if (*end != '\0' || errno == ERANGE || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

inline bool parseInt(const std::string& token, long long* value) {
  if (token.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(token.c_str(), &end, 10);
  if (*end != '\0' || errno == ERANGE) return false;
  *value = v;
  return true;
}

inline std::vector<std::string> splitWhitespace(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> tokens;
  std::string token;
  while (in >> token) tokens.push_back(token);
  return tokens;
}

// A line cut to a readable length for error messages, with bytes that are
// not printable ASCII written as \xNN: a binary file given as a text file
// must not put control characters or broken UTF-8 on the user's terminal.
inline std::string excerpt(const std::string& text, size_t max_chars = 60) {
  std::string s = text;
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
  const bool cut = s.size() > max_chars;
  if (cut) s.resize(max_chars);
  std::string out;
  for (const char c : s) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7f) {
      out.push_back(c);
    } else {
      static const char kHex[] = "0123456789abcdef";
      out += {'\\', 'x', kHex[byte >> 4], kHex[byte & 15]};
    }
  }
  return cut ? out + "..." : out;
}

// a * b, or false when the product does not fit in size_t.
inline bool checkedMultiply(size_t a, size_t b, size_t* product) {
  return !__builtin_mul_overflow(a, b, product);
}

// a + b, or false when the sum does not fit in size_t.
inline bool checkedAdd(size_t a, size_t b, size_t* sum) { return !__builtin_add_overflow(a, b, sum); }

}  // namespace internal
}  // namespace amhmvs
