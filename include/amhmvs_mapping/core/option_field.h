// A documented option of an options struct, by text: its command-line /
// parameter name, its meaning and accessors. Tables of these are the single
// list behind --help, the command-line parsers, ROS parameters and the docs
// (patchMatchOptionTable(), realismOptionTable()).
#pragma once

#include <functional>
#include <sstream>
#include <string>
#include <type_traits>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

template <typename Options>
struct OptionField {
  std::string name;
  std::string help;
  std::function<std::string(const Options&)> get;
  // Throws InputError when the text is not a value of the option's type.
  std::function<void(Options&, const std::string&)> set;
};

// The whole of `text` as a number of type T; InputError naming the option
// otherwise (a minus sign for an unsigned type included).
template <typename T>
T parseOptionNumber(const std::string& name, const std::string& text) {
  if (std::is_unsigned<T>::value && text.find('-') != std::string::npos) {
    throw InputError("option " + name + ": '" + text + "' must not be negative");
  }
  std::istringstream in(text);
  T value;
  if (!(in >> value) || !(in >> std::ws).eof()) {
    throw InputError("option " + name + ": '" + text + "' is not a valid number");
  }
  return value;
}

// The option of a numeric member.
template <typename Options, typename T>
OptionField<Options> numberField(const char* name, T Options::*member, const char* help) {
  return {name, help,
          [member](const Options& o) {
            std::ostringstream out;
            out << o.*member;
            return out.str();
          },
          [member, name](Options& o, const std::string& text) { o.*member = parseOptionNumber<T>(name, text); }};
}

}  // namespace amhmvs
