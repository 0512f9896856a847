// environment_image.h — reading the equirectangular radiance maps of the environment light
// (geometry/environment.h): OpenEXR (.exr, through OpenEXR) and Radiance RGBE (.hdr, through
// stb_image: Debian's libstb-dev), linear float RGB. The size is read from the file's header and
// checked before any pixel is decoded. docs/SCENES.md "Environment".
#pragma once
#include <string>
#include <vector>

namespace pf {

struct RadianceImage {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width × height × 3, row-major, row 0 = the top row of the file
};

// The RGB image of `path` (.exr or .hdr by its extension, case-insensitive). InputError, one line
// naming the file, for a missing file or one that is not a regular file (a directory), another
// extension, an EXR without R, G and B channels, a header whose width is not twice its height,
// a width above `max_width` (refused before decoding), or a file the library cannot decode (a
// damaged or cut file: the library's reason). The texel values are not checked here
// (check_environment_texels, geometry/environment.h).
RadianceImage read_radiance_image(const std::string& path, int max_width);

}  // namespace pf
