// The survey benchmark's scoring (survey_benchmark.h): each surveyed marker against the true
// layout, the naive pairwise-averaging baseline, and the corners' repeated error.
#pragma once

#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "svms/bundle/survey.h"
#include "svms/bundle/view_graph.h"
#include "svms/marker/layout.h"

namespace svms {

// One surveyed marker against the truth.
struct MarkerError {
  int id = -1;
  double position_mm = 0, orientation_deg = 0, nees = -1;  // nees -1: no covariance
  double post_error_mm = 0;                                // estimated - true post height
  double post_sigma_mm = 0;  // the survey's sigma of the post height (0: none)
  bool has_post = false;
};

// Errors of `layout` (frame of marker `ref`) against `truth` (any frame; re-expressed), one per
// marker of `layout` but the reference.
std::vector<MarkerError> Errors(const Layout& layout, const Layout& truth, int ref);

// The RMS of one field of the errors (0 when there are none).
double Rms(const std::vector<MarkerError>& v, double MarkerError::*f);

// A layout (poses only) from root_from_marker poses and the models of `like`.
Layout LayoutFromPoses(const std::map<int, Pose>& poses, const Layout& like);

// The single-marker poses of the markers `ids` in each image, for PairwiseAverageLayout.
std::vector<ImageSightings> Sightings(const std::vector<SurveyImage>& images,
                                      const std::set<int>& ids);

// Each detected corner's error against the truth along its marker's outward diagonal (pixels;
// negative: the black square found smaller than it is), per marker ID. The survey's covariance
// takes corner errors to be independent from view to view: a mean that stands out from its
// standard error is an error that repeats, and no number of views averages it away.
std::map<int, std::vector<double>> OutwardCornerErrors(
    const std::vector<SurveyImage>& images,
    const std::vector<std::pair<std::string, Pose>>& cam_from_object, const Layout& truth,
    const CameraModel& camera);

// Mean of v and its standard error, "m +- se" (pixels, 4 decimals); "-" for fewer than two.
std::string MeanAndStandardError(const std::vector<double>& v);

}  // namespace svms
