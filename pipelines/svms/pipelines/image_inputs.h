// Image inputs of a run: the one expansion of IMAGE | DIR | GLOB | VIDEO that every command
// taking images uses (detect, pose, calibrate, survey).
#pragma once

#include <string>
#include <vector>

namespace svms {

// True when `path`'s extension (any case) is one of the image types the commands read:
// .png .jpg .jpeg .tif .tiff .bmp .pgm .ppm.
bool IsImageFile(const std::string& path);
// True for the video containers read through OpenCV's VideoCapture (FFmpeg): .mp4 .m4v .mov
// .avi .mkv .webm .mpg .mpeg.
bool IsVideoFile(const std::string& path);

// Expands each input in order: a directory gives its image files (IsImageFile), sorted by name;
// a name with a glob character (*?[) gives its matches in glob order; anything else, and a glob
// that matches nothing, is kept as given (so that it fails to read later, named). Video files
// are kept as one input (VideoFrames reads them).
std::vector<std::string> ExpandImageInputs(const std::vector<std::string>& inputs);

}  // namespace svms
