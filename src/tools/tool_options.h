// Option parsing shared by the amhmvs tools: "--name value", "--name=value"
// and value-less switches, values parsed whole ("3abc" is refused).
#pragma once

#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/core/option_field.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace amhmvs {

template <typename T>
T parseValue(const std::string& option, const std::string& text) {
  std::istringstream in(text);
  T value;
  if (!(in >> value) || !(in >> std::ws).eof()) {
    throw InputError("option --" + option + ": '" + text + "' is not a valid value");
  }
  return value;
}

// "x,y,z": three numbers (e.g. a position in metres).
inline Eigen::Vector3d parseVector3(const std::string& option, const std::string& text) {
  std::istringstream in(text);
  std::string item;
  std::vector<double> values;
  while (std::getline(in, item, ',')) values.push_back(parseValue<double>(option, item));
  if (values.size() != 3) throw InputError("option --" + option + ": expected x,y,z, got '" + text + "'");
  return {values[0], values[1], values[2]};
}

// Reads the option at arguments[*i] (advancing *i past its value): its name
// without "--" and its value. A name in `switches` takes no separate value
// (its value is "" unless given as --name=value). Throws InputError for a
// positional argument or a missing value.
inline void nextOption(const std::vector<std::string>& arguments, size_t* i,
                       const std::set<std::string>& switches, std::string* name, std::string* value) {
  const std::string& arg = arguments[*i];
  if (arg.rfind("--", 0) != 0) throw InputError("unexpected argument '" + arg + "'");
  *name = arg.substr(2);
  value->clear();
  const size_t eq = name->find('=');
  if (eq != std::string::npos) {
    *value = name->substr(eq + 1);
    *name = name->substr(0, eq);
  } else if (switches.count(*name)) {
    // a switch without a value
  } else if (*i + 1 < arguments.size()) {
    *value = arguments[++*i];
  } else {
    throw InputError("option --" + *name + " needs a value");
  }
}

// A switch's value: "" (given alone), 1/true/yes or 0/false/no.
inline bool parseSwitch(const std::string& option, const std::string& value) {
  return parseSwitchText("--" + option, value);
}

// Sets the option `name` of `table` from text; false when the table has no
// such option. Throws InputError for a bad value.
template <typename Options>
bool setOptionFromTable(const std::vector<OptionField<Options>>& table, const std::string& name,
                        const std::string& value, Options* options) {
  for (const OptionField<Options>& info : table) {
    if (info.name == name) {
      info.set(*options, value);
      return true;
    }
  }
  return false;
}

// Sets the method option `name` (patchMatchOptionTable()) from text; false
// when there is no such option. Throws InputError for a bad value.
inline bool setPatchMatchOption(const std::string& name, const std::string& value, PatchMatchOptions* options) {
  return setOptionFromTable(patchMatchOptionTable(), name, value, options);
}

}  // namespace amhmvs
