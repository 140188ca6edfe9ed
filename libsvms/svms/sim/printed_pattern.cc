// Surface patterns and the ring's bit table (printed_pattern.h).
#include "svms/sim/printed_pattern.h"

#include "svms/codec/svms44.h"
#include "svms/sim/render_hash.h"

namespace svms::render {
namespace {

RingBitTable MakeRingBitTable() {
  constexpr int n = MarkerModel::kCellsPerSide;
  RingBitTable table;
  for (auto& row : table) row.fill(-1);
  MarkerModel unit;  // cell side 1: cell centres at half-integers
  unit.cell_size = 1;
  for (int i = 0; i < Svms44::kBits; ++i) {
    const Eigen::Vector2d c = unit.BitCellCentre(i);
    table[static_cast<int>(std::floor(0.5 * n - c.y()))]
         [static_cast<int>(std::floor(c.x() + 0.5 * n))] = i;
  }
  for (auto& row : table)
    for (int8_t& bit : row)
      if (bit < 0) bit = row[0];
  return table;
}

}  // namespace

const RingBitTable kRingBits = MakeRingBitTable();

double PatternAt(const Material& m, double u, double v) {
  const Pattern& p = m.pattern;
  auto cell = [&](double w) { return static_cast<int64_t>(std::floor(w / p.period)); };
  switch (p.kind) {
    case Pattern::Kind::kUniform:
      return m.reflectance;
    case Pattern::Kind::kChecker: {
      if (p.cols > 0) {
        const double hu = 0.5 * p.cols * p.period, hv = 0.5 * p.rows * p.period;
        if (std::abs(u) >= hu || std::abs(v) >= hv) return p.high;
        return ((cell(u + hu) + cell(v + hv)) & 1) ? p.high : p.low;
      }
      return ((cell(u) + cell(v)) & 1) ? p.high : p.low;
    }
    case Pattern::Kind::kStripes:
      return (cell(u) & 1) ? p.high : p.low;
    case Pattern::Kind::kGrid: {
      const double fu = u - p.period * std::floor(u / p.period),
                   fv = v - p.period * std::floor(v / p.period);
      return (fu < p.line || fv < p.line) ? p.low : p.high;
    }
    case Pattern::Kind::kText: {
      // Lines of blocky 5 x 7 glyphs in cells of `period` (wide) x 1.6 period (tall).
      const double gw = p.period, gh = 1.6 * p.period;
      const int64_t gx = static_cast<int64_t>(std::floor(u / gw)),
                    gy = static_cast<int64_t>(std::floor(v / gh));
      const uint64_t g =
          Mix(p.seed ^ Mix(static_cast<uint64_t>(gx) * 0x9e37ULL ^ Mix(static_cast<uint64_t>(gy))));
      if ((g & 7) == 0) return p.high;                                      // a space
      const int px = static_cast<int>(std::floor((u - gx * gw) / gw * 6));  // 5 columns + gap
      const int py = static_cast<int>(std::floor((v - gy * gh) / gh * 9));  // 7 rows + gaps
      if (px >= 5 || py < 1 || py > 7) return p.high;
      return ((Mix(g + py) >> px) & 1) ? p.low : p.high;
    }
    case Pattern::Kind::kNoise: {
      const uint64_t h = Mix(p.seed ^ Mix(static_cast<uint64_t>(cell(u)) * 0x51ULL ^
                                          Mix(static_cast<uint64_t>(cell(v)))));
      return p.low + (p.high - p.low) * ((h >> 11) * 0x1.0p-53);
    }
  }
  return m.reflectance;
}

}  // namespace svms::render
