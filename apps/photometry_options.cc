#include "photometry_options.h"

namespace svms::cli {

void AddPhotometryOptions(CLI::App* cmd, PhotometryOptions* o) {
  cmd->add_option("--response", o->response,
                  "The images' response curve: linear, srgb, gamma:G or table:FILE (default: the "
                  "camera's photometric file, else what the file declares, else srgb for 8-bit "
                  "and linear for 16-bit images; docs/conventions.md)");
  cmd->add_option("--black-level", o->black_level, "Pixel value of no light (raw sensors)");
  cmd->add_option("--white-level", o->white_level,
                  "Pixel value of saturation (e.g. 4095 for 12 bits in a 16-bit file)");
  cmd->add_option("--bayer", o->bayer,
                  "The images are raw Bayer mosaics: RGGB, BGGR, GRBG or GBRG (turned into "
                  "luminance in linear light, --demosaic)");
  cmd->add_option("--demosaic", o->demosaic,
                  "How a Bayer mosaic becomes luminance: luminance (white-balanced mosaic "
                  "through a frequency-selection filter, which cannot move edges; the default) "
                  "or opencv (OpenCV's edge-aware demosaic)");
}

}  // namespace svms::cli
