// Text outputs: see text_file.h.
#include "photonflow/text_file.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "photonflow/error.h"

namespace pf {

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += char(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp." + std::to_string(long(getpid()));
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw input_error(path, "cannot create the file", "check the directory");
    f << text;
    if (!f.flush()) {
      f.close();
      std::remove(tmp.c_str());
      throw input_error(path, "cannot write the file", "disk full?");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw input_error(path, "cannot write the file", "check the directory and its permissions");
  }
}

}  // namespace pf
