// A documented option of an options struct, by text: its command-line /
// parameter name, its meaning and accessors. Tables of these are the single
// list behind --help, the command-line parsers, ROS parameters and the docs
// (patchMatchOptionTable(), realismOptionTable()).
#pragma once

#include <functional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {

template <typename Options>
struct OptionField {
  using Getter = std::function<std::string(const Options&)>;
  using Setter = std::function<void(Options&, const std::string&)>;
  OptionField() = default;
  OptionField(std::string name_, std::string help_, Getter get_, Setter set_, bool is_switch_ = false,
              bool advanced_ = false, std::string alias_ = {})
      : name(std::move(name_)), help(std::move(help_)), get(std::move(get_)), set(std::move(set_)),
        is_switch(is_switch_), advanced(advanced_), alias(std::move(alias_)) {}

  std::string name;
  std::string help;
  Getter get;
  // Throws InputError when the text is not a value of the option's type.
  Setter set;
  bool is_switch = false;  // true/false; on a command line "--name" alone means true
  bool advanced = false;   // tuning most users never need (listed apart in the docs)
  std::string alias;       // an older command-line name that still works (amhmvs_map), or empty
};

// The same field with `advanced` set.
template <typename Options>
OptionField<Options> advanced(OptionField<Options> field) {
  field.advanced = true;
  return field;
}

// The same field with a command-line alias.
template <typename Options>
OptionField<Options> withAlias(OptionField<Options> field, const char* alias) {
  field.alias = alias;
  return field;
}

// Whether `text` is a switch value: true for "", 1, true, yes; false for 0,
// false, no; InputError naming the option otherwise.
inline bool parseSwitchText(const std::string& name, const std::string& text) {
  if (text.empty() || text == "1" || text == "true" || text == "yes") return true;
  if (text == "0" || text == "false" || text == "no") return false;
  throw InputError("option " + name + ": '" + text + "' is not true/false (1/0)");
}

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

// The option of a bool member (text true/false).
template <typename Options>
OptionField<Options> switchField(const char* name, bool Options::*member, const char* help) {
  OptionField<Options> field{name, help,
                             [member](const Options& o) { return std::string(o.*member ? "true" : "false"); },
                             [member, name](Options& o, const std::string& text) {
                               o.*member = parseSwitchText(name, text);
                             }};
  field.is_switch = true;
  return field;
}

// The fields of a member struct's table as fields of the outer struct, named
// "group/name": `member` gives the inner struct of an outer one.
template <typename Outer, typename Inner>
std::vector<OptionField<Outer>> nestedFields(const std::string& group, Inner& (*member)(Outer&),
                                             const std::vector<OptionField<Inner>>& table) {
  std::vector<OptionField<Outer>> fields;
  for (const OptionField<Inner>& inner : table) {
    OptionField<Outer> field{group + "/" + inner.name, inner.help,
                             [member, get = inner.get](const Outer& o) { return get(member(const_cast<Outer&>(o))); },
                             [member, set = inner.set](Outer& o, const std::string& text) { set(member(o), text); },
                             inner.is_switch, inner.advanced, inner.alias};
    fields.push_back(std::move(field));
  }
  return fields;
}

}  // namespace amhmvs
