// make_depfile.cpp — make dependency files (make_depfile.h).
#include "photonflow/foundations/make_depfile.h"

#include <set>
#include <stdexcept>

namespace pf {

bool make_safe_name(const std::string& name) {
  if (name.empty() || name[0] == '-' || name[0] == '~') return false;
  for (unsigned char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '/' || c == '+' || c == '@' || c == ',' ||
                    c == '-' || c == '~';
    if (!ok) return false;
  }
  return true;
}

std::string make_depfile_text(const std::string& target, const std::vector<std::string>& inputs,
                              size_t* left_out) {
  if (!make_safe_name(target))
    throw std::invalid_argument("make_depfile_text: the target is not a make-safe name");
  std::vector<std::string> names;
  std::set<std::string> seen;
  size_t unsafe = 0;
  for (const std::string& in : inputs) {
    if (!make_safe_name(in)) {
      ++unsafe;
      continue;
    }
    if (seen.insert(in).second) names.push_back(in);
  }
  if (left_out) *left_out = unsafe;
  std::string text = "# the files " + target + " was made from (make reads this file)";
  if (unsafe > 0)
    text += "; " + std::to_string(unsafe) + " left out: names make would read as syntax";
  text += "\n" + target + ":";
  for (const std::string& n : names) text += " \\\n  " + n;
  text += "\n";
  for (const std::string& n : names) text += n + ":\n";
  return text;
}

}  // namespace pf
