// A scene for the simulator: a camera, light, objects carrying markers, occluders, a
// background, and the views (camera poses) to render. Read from JSON ("type": "svms.scene",
// documented in docs/simulator.md) with the same strictness as the model files: every field
// named in errors, unknown fields rejected.
//
// World frame: any right-handed frame the scene chooses; metres. Radiance is in relative
// units: a white Lambertian surface (reflectance 1) facing a sun of irradiance 1 has radiance 1.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"
#include "svms/geometry/pose.h"
#include "svms/marker/marker_model.h"

namespace svms {

// A printed or painted pattern on an object's surface, in the surface's own coordinates
// (a plane's x, y; on a box face, the face's two in-plane object axes), metres.
struct Pattern {
  enum class Kind { kUniform, kChecker, kStripes, kGrid, kText, kNoise };
  Kind kind = Kind::kUniform;
  double period = 0.05;            // square / stripe / grid / glyph / noise cell size
  double low = 0.05, high = 0.85;  // the two reflectances (noise: the range)
  double line = 0.005;             // grid line width
  int cols = 0, rows = 0;          // checker: a board of cols x rows squares centred on the origin
                                   // with a `high` border around it (0: unbounded)
  uint64_t seed = 0;               // text and noise layouts
};

struct Material {
  Pattern pattern;           // overrides `reflectance` where it is not kUniform
  double reflectance = 0.3;  // diffuse albedo in [0, 1]
  double specular = 0;       // strength of a glossy highlight (Blinn-Phong), >= 0
  double shininess = 50;     // its exponent
};

// What is printed on a scene marker: the svms44 pattern of its model (the default), or a peer
// system's planar tag for the comparison benchmark (bench compare). A peer tag is an n x n grid
// of square cells, outer black border included, printed so that its outer black edge is the
// model's black square (side model.size; same corners, so the same truth corners and the same
// pose reference); the rest of the model's decal (out to half_extent()) is white, a quiet
// zone. The grid comes from the peer's own library (peers/svms/peers/peer_tags.h); the core only
// prints it. No nested marker with a peer tag; the post is whatever the model says.
struct PrintedTag {
  std::string family = "svms44";  // "svms44", or a peer family's name (e.g. "tag36h11")
  int n = 0;                      // peer: cells per side (border included), >= 3
  std::vector<uint8_t> white;     // peer: n * n, row-major, row 0 at the top as printed
  bool peer() const { return family != "svms44"; }
  // The interior (data) cell centres of a peer grid, marker frame, metres, for a black edge of
  // side `size`: row by row from the top-left, (n - 2)^2 of them.
  std::vector<Eigen::Vector2d> DataCellCentres(double size) const;
  Status Validate(const std::string& path) const;
};

struct SceneMarker {
  MarkerModel model;
  Pose object_from_marker;
  PrintedTag print;        // svms44 unless a peer tag is printed instead
  double black = 0.04;     // reflectance of the black print (black paint is not zero)
  double white = 0.85;     // reflectance of the white print
  bool retro = false;      // white parts retro-reflective (bright under the ring light)
  double retro_gain = 50;  // their brightness under the ring light, relative to diffuse white
};

struct SceneObject {
  enum class Shape { kPlane, kBox };
  std::string name;
  Shape shape = Shape::kPlane;
  // Box: full extents along x, y, z, centred on the object origin. Plane: extents along x and
  // y (z ignored) in the object's z = 0 plane, facing +z.
  Eigen::Vector3d size = Eigen::Vector3d::Ones();
  Pose world_from_object;
  Material material;
  std::vector<SceneMarker> markers;
};

struct Occluder {
  enum class Shape { kBar, kBlob };  // a box, or a sphere
  Shape shape = Shape::kBar;
  Pose world_from_occluder;
  Eigen::Vector3d size = Eigen::Vector3d::Ones();  // bar: full extents; blob: radius = size.x()
  double reflectance = 0.2;
};

struct Sun {
  Eigen::Vector3d to_sun_world = Eigen::Vector3d::UnitZ();  // unit direction toward the sun
  double irradiance = 1;
  double angular_diameter_deg = 0.53;
};

struct Lighting {
  std::optional<Sun> sun;
  double ambient = 0;                 // uniform irradiance, no shadows
  std::optional<Sun> earthshine;      // a broad directional fill, no shadows
  double ring_light = 0;              // irradiance at 1 m from a light at the camera centre
  bool narrow_band_filter = false;    // a filter passing only the ring light's band
  double filter_transmission = 0.03;  // what the filter lets through of sun, ambient, earth
};

struct Sensor {
  int bits = 8;                 // 8 or 16
  double exposure = 12000;      // electrons collected at radiance 1
  double full_well = 15000;     // electrons at the largest pixel value
  double read_noise = 4;        // electrons RMS
  bool shot_noise = true;       // Poisson photon noise
  double defocus_sigma_px = 0;  // Gaussian blur of the optics, pixels
  double vignetting = 0;        // brightness falls by this fraction at the image corners
  int rays_per_pixel = 16;      // stratified supersampling: a square number >= 1
  // Pixels on an edge (EdgePixels, render.h: a bend or a jump in the first pass's radiance)
  // rendered again with this many rays, a square number up to 4096, where that is
  // above rays_per_pixel; 0: off. 16 jittered rays estimate an edge pixel's coverage to about
  // 5 % of the edge's contrast, several times the shot noise of a sunlit white (about 1 %);
  // 256 bring that under 1 %.
  int edge_rays_per_pixel = 0;
  double motion_blur = 0;  // exposure as a fraction of the way to the next view, [0, 1]

  // The camera's transfer from electrons to stored values (docs/simulator.md, "Camera pipeline
  // and sensor profiles"): s = electrons / full_well in [0, 1] (below 0 for a lossless linear raw
  // frame, docs/simulator.md), e = response(s), DN = black_level + e * (white - black_level) with
  // white = 2^signal_bits - 1, rounded. The defaults store linear light in all `bits`, as a grey
  // PNG.
  //
  // The response curve as Response::Parse reads it: "linear", "srgb" or "gamma:G" (no tables:
  // a scene carries no side files).
  std::string response = "linear";
  // Bits of signal in the container, LSB-aligned (12 in a 16-bit container: 0..4095);
  // 0: all of `bits`. Otherwise 6 to `bits`.
  int signal_bits = 0;
  // Stored value of no light (a raw sensor's offset), container units; below the white level.
  double black_level = 0;
  // "" (grey), or the colour filter array's 2x2 pattern from the top-left pixel: "RGGB",
  // "BGGR", "GRBG", "GBRG". The image is then a one-channel mosaic whose pixels collect
  // channel_gain[c] times the electrons of a grey pixel, c their colour (0 red, 1 green, 2 blue).
  std::string bayer;
  std::array<double, 3> channel_gain = {0.55, 1.0, 0.75};  // relative quantum efficiency, r g b
  // How the image is stored: "png" (lossless, declares its response) or "jpeg" (8 bits only,
  // through libjpeg at jpeg_quality, 1 to 100).
  std::string format = "png";
  int jpeg_quality = 85;

  // 2^signal_bits - 1 (2^bits - 1 when signal_bits is 0): the stored value of saturation. For
  // a sensor that passes CheckSensor.
  int white_level() const { return (1 << (signal_bits > 0 ? signal_bits : bits)) - 1; }
};

// Checks the sensor's camera pipeline (bits, response, signal_bits, black_level, bayer,
// channel_gain, format, jpeg_quality) as a whole; the message names the field, as
// "sensor.signal_bits: expected 0 (all of sensor.bits) or 6 to 8 (sensor.bits), got the number
// 12". Scene::Validate calls it, so scenes built in code meet the same rules as scene files.
Status CheckSensor(const Sensor& sensor);

// Named camera pipelines, for `svms render --profile`, `svms dataset --profile` and the
// benchmarks: "linear" (8-bit linear PNG: the default sensor), "srgb8" (8-bit sRGB PNG behind
// optics of 0.7 px blur), "jpeg_srgb" (the same as a JPEG of quality 85), "raw12" (12 bits of
// linear signal in a 16-bit PNG above a black level of 256), "raw12_bayer" (raw12 through an
// RGGB colour filter array). In that order.
const std::vector<std::string>& SensorProfileNames();
// Sets the fields of the camera pipeline (bits, response, signal_bits, black_level, bayer,
// channel_gain, format, jpeg_quality; defocus_sigma_px for the srgb8 and jpeg_srgb profiles) to
// the profile's; the light (exposure, full_well), the noise and the sampling stay the scene's.
// An unknown name is an error that lists the names, and leaves *sensor as it was.
Status ApplySensorProfile(const std::string& name, Sensor* sensor);

struct Background {
  enum class Kind { kBlack, kEarth, kImage };
  Kind kind = Kind::kBlack;
  double brightness = 0.5;  // radiance scale of earth or image
  std::string image_path;   // kImage: an image stretched over the frame (behind everything)
};

struct View {
  View() = default;
  View(std::string name, const Pose& cam_from_world, std::optional<Sun> sun = std::nullopt,
       std::optional<std::vector<Occluder>> occluders = std::nullopt)
      : name(std::move(name)),
        cam_from_world(cam_from_world),
        sun(std::move(sun)),
        occluders(std::move(occluders)) {}
  std::string name;
  Pose cam_from_world;
  std::optional<Sun> sun;                          // overrides the scene's sun
  std::optional<std::vector<Occluder>> occluders;  // replaces the scene's occluders
};

struct Scene {
  uint64_t seed = 1;
  CameraModel camera;
  Sensor sensor;
  Lighting light;
  Background background;
  std::vector<SceneObject> objects;
  std::vector<Occluder> occluders;
  std::vector<View> views;

  Status Validate() const;
};

// Parses and validates a scene. Relative file names (camera model, background image) are
// resolved against `base_dir`. Errors read "<source>: <field path>: expected ..., got ...".
Status ParseSceneJson(const std::string& text, const std::string& source,
                      const std::string& base_dir, Scene* out);
Status ReadSceneFile(const std::string& path, Scene* out);
// The scene as JSON (camera inline), such that ParseSceneJson gives it back.
std::string SceneToJson(const Scene& scene);
// sensor.edge_rays_per_pixel is 0, or a square number of at most 4096.
bool ValidEdgeRays(const Sensor& sensor);

}  // namespace svms
