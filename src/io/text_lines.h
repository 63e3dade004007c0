// Internal: whitespace-separated text files (pose lists, matrices) as numbered
// lines of tokens, with errors that name the file and the line.
#pragma once

#include <sstream>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "file_util.h"

namespace amhmvs {
namespace internal {

struct TextLine {
  int number = 0;  // 1-based
  std::vector<std::string> tokens;
};

// The non-blank lines of a file that do not start with '#'.
inline std::vector<TextLine> readTextLines(const std::string& path) {
  std::istringstream in(readFileBytes(path));
  std::vector<TextLine> lines;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    std::vector<std::string> tokens = splitWhitespace(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    lines.push_back({number, std::move(tokens)});
  }
  return lines;
}

[[noreturn]] inline void failAt(const std::string& path, int line, const std::string& problem) {
  throw InputError(path + ": line " + std::to_string(line) + ": " + problem);
}

// Checks the token count of a line.
inline void expectTokens(const std::string& path, const TextLine& line, size_t count,
                         const std::string& what) {
  if (line.tokens.size() != count) {
    failAt(path, line.number, "expected " + std::to_string(count) + " fields (" + what + "), got " +
                                  std::to_string(line.tokens.size()));
  }
}

// Token `index` of a line as a finite number.
inline double numberAt(const std::string& path, const TextLine& line, size_t index) {
  double value = 0;
  if (index >= line.tokens.size() || !parseDouble(line.tokens[index], &value)) {
    failAt(path, line.number,
           "field " + std::to_string(index + 1) + " '" +
               (index < line.tokens.size() ? excerpt(line.tokens[index], 20) : std::string()) +
               "' is not a finite number");
  }
  return value;
}

// A file that holds exactly a rows x cols matrix of numbers (one row a line).
inline std::vector<std::vector<double>> readMatrixFile(const std::string& path, size_t rows,
                                                       size_t cols) {
  const std::vector<TextLine> lines = readTextLines(path);
  if (lines.size() != rows) {
    throw InputError(path + ": expected a " + std::to_string(rows) + "x" + std::to_string(cols) +
                     " matrix (" + std::to_string(rows) + " lines of numbers), found " +
                     std::to_string(lines.size()) + " lines");
  }
  std::vector<std::vector<double>> matrix(rows, std::vector<double>(cols));
  for (size_t r = 0; r < rows; ++r) {
    expectTokens(path, lines[r], cols, "a matrix row");
    for (size_t c = 0; c < cols; ++c) matrix[r][c] = numberAt(path, lines[r], c);
  }
  return matrix;
}

}  // namespace internal
}  // namespace amhmvs
