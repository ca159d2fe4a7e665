// Synthetic DEM + river network generator (see synthetic.h for the contract).
//
// Terrain: value noise summed over octaves (fBm) plus an eastward ramp, shaped by e^2 so that the
// west is wide low flats and the east rough mountains. Rivers: Langbein & Leopold's sine-generated
// curves (heading = omega * sin(2 pi s / lambda) along arc length s), whose tight meanders do not
// self-intersect for omega below ~2.2 rad, with lambda / omega redrawn every half wave and a weak
// pull back to the river's band centre. Every segment is checked against all accepted segments
// with a clearance as it is made (a main river's half wave that fails is redrawn calmer; a
// tributary that fails is dropped), so "no crossing" holds by verification, not by hope. Main
// rivers run west to east in horizontal bands, tributaries leave them at the outer apex of a bend.
// All geometry is generated in cell units.
#include "synthetic.h"

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <filesystem>
#include <system_error>

#include "atomicfile.h"
#include "gdal_errors.h"
#include "pointset.h"

namespace unilod {

namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kTwoPi = 6.283185307179586;
constexpr double kHalfPi = 1.5707963267948966;

// --- Deterministic numbers ------------------------------------------------------------------

std::uint64_t splitmix64(std::uint64_t& state) {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

std::uint64_t hash64(std::uint64_t x) {
    return splitmix64(x);
}

// xoshiro256** (Blackman & Vigna), seeded through splitmix64 as its authors recommend.
class Rng {
public:
    explicit Rng(std::uint64_t seed) {
        for (std::uint64_t& w : s_)
            w = splitmix64(seed);
    }
    std::uint64_t next() {
        const std::uint64_t result = std::rotl(s_[1] * 5, 7) * 9;
        const std::uint64_t t = s_[1] << 17;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = std::rotl(s_[3], 45);
        return result;
    }
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
    double uniform(double a, double b) { return a + (b - a) * uniform(); }
    bool chance(double p) { return uniform() < p; }
    std::uint64_t below(std::uint64_t n) { return next() % n; }  // bias < n / 2^64: irrelevant

private:
    std::uint64_t s_[4];
};

// sin with basic IEEE operations only (libm's sin may differ in the last bit between platforms):
// reduction to [-pi/2, pi/2] and the Taylor series to x^13, error < 1e-9.
double detSin(double x) {
    x -= kTwoPi * std::floor(x / kTwoPi + 0.5);  // [-pi, pi]
    if (x > kHalfPi) {
        x = kPi - x;
    } else if (x < -kHalfPi) {
        x = -kPi - x;
    }
    const double x2 = x * x;
    return x * (1.0 + x2 * (-1.0 / 6 +
                            x2 * (1.0 / 120 +
                                  x2 * (-1.0 / 5040 +
                                        x2 * (1.0 / 362880 + x2 * (-1.0 / 39916800 +
                                                                   x2 * (1.0 / 6227020800.0)))))));
}
double detCos(double x) {
    return detSin(x + kHalfPi);
}

// --- Terrain ---------------------------------------------------------------------------------

// One octave of value noise: random values on a square lattice of `wavelength` cells, smoothly
// interpolated. Column interpolation terms are precomputed once (they repeat on every row).
struct Octave {
    double wavelength = 0, amplitude = 0;
    int nx = 0, ny = 0;
    std::vector<double> lattice;
    std::vector<int> col;      // per grid column: lattice column
    std::vector<double> colT;  // per grid column: smoothed fraction
};

double smooth(double t) {
    return t * t * (3.0 - 2.0 * t);
}

// Altitudes (row 0 north) in metres.
std::vector<float> generateTerrain(int width, int height, std::uint64_t seed, double roughness) {
    std::vector<Octave> octaves;
    const std::uint64_t seedHash = hash64(seed ^ 0x7465727261696E00ull);  // "terrain"
    double wavelength = std::max(width, height) / 2.0, amplitude = 1.0, amplitudeSum = 0;
    for (int o = 0; o < 16 && (o == 0 || wavelength >= 2.5); ++o) {
        Octave oct;
        oct.wavelength = wavelength;
        oct.amplitude = amplitude;
        oct.nx = static_cast<int>(width / wavelength) + 2;
        oct.ny = static_cast<int>(height / wavelength) + 2;
        oct.lattice.resize(static_cast<std::size_t>(oct.nx) * oct.ny);
        for (int iy = 0; iy < oct.ny; ++iy) {
            for (int ix = 0; ix < oct.nx; ++ix) {
                const std::uint64_t h =
                    hash64(seedHash ^ (static_cast<std::uint64_t>(o) << 58) ^
                           (static_cast<std::uint64_t>(iy) << 29) ^ static_cast<std::uint64_t>(ix));
                oct.lattice[static_cast<std::size_t>(iy) * oct.nx + ix] =
                    static_cast<double>(h >> 11) * 0x1.0p-53;
            }
        }
        oct.col.resize(width);
        oct.colT.resize(width);
        for (int c = 0; c < width; ++c) {
            const double g = (c + 0.5) / wavelength;
            const double f = std::floor(g);
            oct.col[c] = static_cast<int>(f);
            oct.colT[c] = smooth(g - f);
        }
        amplitudeSum += amplitude;
        octaves.push_back(std::move(oct));
        wavelength *= 0.5;
        amplitude *= roughness;
    }

    std::vector<float> z(static_cast<std::size_t>(width) * height);
    std::vector<double> acc(width);
    for (int r = 0; r < height; ++r) {
        const double v = height - r - 0.5;  // cell units, upward from the south edge
        std::fill(acc.begin(), acc.end(), 0.0);
        for (const Octave& oct : octaves) {
            const double g = v / oct.wavelength;
            const double f = std::floor(g);
            const int iy = static_cast<int>(f);
            const double ty = smooth(g - f);
            const double* row0 = oct.lattice.data() + static_cast<std::size_t>(iy) * oct.nx;
            const double* row1 = row0 + oct.nx;
            for (int c = 0; c < width; ++c) {
                const int ix = oct.col[c];
                const double tx = oct.colT[c];
                const double a = row0[ix] + (row0[ix + 1] - row0[ix]) * tx;
                const double b = row1[ix] + (row1[ix + 1] - row1[ix]) * tx;
                acc[c] += oct.amplitude * (a + (b - a) * ty);
            }
        }
        float* out = z.data() + static_cast<std::size_t>(r) * width;
        for (int c = 0; c < width; ++c) {
            // fBm clusters around 0.5: stretch it, then add the eastward ramp. e^2 keeps the
            // west (e < 0.5: < 500 m) flat and the east (e > 0.71: > 1000 m) steep.
            const double n = std::clamp((acc[c] / amplitudeSum - 0.5) * 2.4 + 0.5, 0.0, 1.0);
            const double e =
                std::clamp(0.15 + 0.7 * ((c + 0.5) / width) + 0.5 * (n - 0.5), 0.0, 1.0);
            out[c] = static_cast<float>(2000.0 * e * e);
        }
    }
    return z;
}

// --- River geometry --------------------------------------------------------------------------

struct Seg {
    XY a, b;
    int line;   // index in the accepted / candidate lines
    int index;  // segment i joins vertices i and i + 1
};

double orient(const XY& a, const XY& b, const XY& c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

double pointSegmentDistance2(const XY& p, const XY& a, const XY& b) {
    const double dx = b.x - a.x, dy = b.y - a.y;
    const double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double ex = a.x + t * dx - p.x, ey = a.y + t * dy - p.y;
    return ex * ex + ey * ey;
}

// Squared distance between two segments; 0 when they cross. Floating point is enough here: the
// generator only accepts pairs farther apart than a clearance far above rounding error.
double segmentDistance2(const Seg& s, const Seg& t) {
    const double o1 = orient(s.a, s.b, t.a), o2 = orient(s.a, s.b, t.b);
    const double o3 = orient(t.a, t.b, s.a), o4 = orient(t.a, t.b, s.b);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) {
        return 0;
    }
    return std::min({pointSegmentDistance2(s.a, t.a, t.b), pointSegmentDistance2(s.b, t.a, t.b),
                     pointSegmentDistance2(t.a, s.a, s.b), pointSegmentDistance2(t.b, s.a, s.b)});
}

// Accepted segments bucketed on a coarse grid, with rollback of a rejected candidate line.
class SegmentIndex {
public:
    SegmentIndex(double width, double height, double bucket, double clearance)
        : bucket_(bucket), clearance_(clearance) {
        nx_ = static_cast<int>(width / bucket) + 1;
        ny_ = static_cast<int>(height / bucket) + 1;
        cells_.resize(static_cast<std::size_t>(nx_) * ny_);
    }

    std::size_t mark() const { return segs_.size(); }

    // Removes the segments added after `mark`. They are the last entries of their buckets, so
    // popping in reverse insertion order restores every bucket.
    void rollback(std::size_t mark) {
        while (segs_.size() > mark) {
            forBuckets(segs_.back(), [](std::vector<std::uint32_t>& b) { b.pop_back(); });
            segs_.pop_back();
        }
    }

    // Adds `s` unless a segment closer than the clearance exists; `skip(other)` exempts pairs
    // that legitimately touch (neighbours in a line, the segments at a junction).
    template <class Skip>
    bool tryAdd(const Seg& s, Skip skip) {
        const double c2 = clearance_ * clearance_;
        bool clear = true;
        forBuckets(s, [&](std::vector<std::uint32_t>& b) {
            for (std::uint32_t i : b) {
                if (!clear) return;
                const Seg& o = segs_[i];
                if (!skip(o) && segmentDistance2(s, o) < c2) clear = false;
            }
        });
        if (!clear) return false;
        const auto id = static_cast<std::uint32_t>(segs_.size());
        segs_.push_back(s);
        forBuckets(s, [id](std::vector<std::uint32_t>& b) { b.push_back(id); });
        return true;
    }

private:
    template <class F>
    void forBuckets(const Seg& s, F f) {
        const auto cell = [&](double v, int n) {
            return std::clamp(static_cast<int>(std::floor(v / bucket_)), 0, n - 1);
        };
        const int x0 = cell(std::min(s.a.x, s.b.x) - clearance_, nx_);
        const int x1 = cell(std::max(s.a.x, s.b.x) + clearance_, nx_);
        const int y0 = cell(std::min(s.a.y, s.b.y) - clearance_, ny_);
        const int y1 = cell(std::max(s.a.y, s.b.y) + clearance_, ny_);
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x)
                f(cells_[static_cast<std::size_t>(y) * nx_ + x]);
        }
    }

    double bucket_, clearance_;
    int nx_ = 0, ny_ = 0;
    std::vector<Seg> segs_;
    std::vector<std::vector<std::uint32_t>> cells_;
};

constexpr double kMargin = 1.5;        // cells kept free along the grid border
constexpr double kClearance = 0.2;     // cells between any two non-adjacent river segments
constexpr double kMinWavelength = 16;  // cells: keeps the turn per vertex below ~0.6 rad

struct RiverPlan {
    int width = 0, height = 0;
    int mains = 0;
    double band = 0;  // band height per main river (cells)
};

RiverPlan planRivers(int width, int height, int requested) {
    RiverPlan plan{width, height, 0, 0};
    const double usable = height - 2 * kMargin;
    int n = requested > 0 ? requested : static_cast<int>(std::lround(height / 70.0));
    if (requested <= 0) n = std::clamp(n, 2, 24);
    // A band must hold a meander belt of the smallest wavelength plus tributaries.
    n = std::min(n, static_cast<int>(usable / 12.0));
    if (width < 1.5 * kMinWavelength) n = 0;  // no room for a single meander
    plan.mains = std::max(n, 0);
    plan.band = plan.mains > 0 ? usable / plan.mains : 0;
    return plan;
}

// A meandering walk: heading = base + omega * sin(phase) (+ a pull towards vCentre for main
// rivers), phase advancing 2 pi per wavelength of arc; wavelength and omega are redrawn at every
// half wave (where sin(phase) = 0, so the heading stays continuous).
struct MeanderStyle {
    double minWavelength, maxWavelength;
    double minOmega, maxOmega;
    double tightChance, tightMinOmega, tightMaxOmega;
};

struct Walker {
    Rng& rng;
    MeanderStyle style;
    double omegaScale;
    double phase = 0, wavelength = 0, omega = 0;
    long halfWave = -1;

    // Draws the wavelength and omega of the half wave starting now (scale: calmer retries).
    void beginHalfWave(double scale) {
        halfWave = static_cast<long>(std::floor(phase / kPi));
        wavelength = rng.uniform(style.minWavelength, style.maxWavelength);
        omega = rng.chance(style.tightChance)
                    ? rng.uniform(style.tightMinOmega, style.tightMaxOmega)
                    : rng.uniform(style.minOmega, style.maxOmega);
        omega *= omegaScale * scale;
    }

    // One step of length ds from p with the given base heading; returns the new vertex.
    XY step(const XY& p, double base, double ds) {
        const double dphi = kTwoPi * ds / wavelength;
        const double heading = base + omega * detSin(phase + 0.5 * dphi);
        phase += dphi;
        return {p.x + ds * detCos(heading), p.y + ds * detSin(heading)};
    }

    // step(), drawing a new half wave whenever the phase enters one.
    XY stepAuto(const XY& p, double base, double ds) {
        if (static_cast<long>(std::floor(phase / kPi)) != halfWave) beginHalfWave(1.0);
        return step(p, base, ds);
    }
};

bool insideBox(const XY& p, double x0, double x1, double y0, double y1) {
    return p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1;
}

// Adds all segments of `line` (line id `id`) to the index, or none. `skipAtEnd(o)` exempts the
// pairs of the line's last segment with the segments at its junction.
template <class SkipAtEnd>
bool addLine(SegmentIndex& index, const RiverLine& line, int id, SkipAtEnd skipAtEnd) {
    const std::size_t mark = index.mark();
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        const Seg s{line[i], line[i + 1], id, static_cast<int>(i)};
        const bool last = i + 2 == line.size();
        const auto skip = [&](const Seg& o) {
            if (o.line == id && std::abs(o.index - s.index) <= 1) return true;
            return last && skipAtEnd(o);
        };
        if (!index.tryAdd(s, skip)) {
            index.rollback(mark);
            return false;
        }
    }
    return true;
}

double pathLength(const RiverLine& line) {
    double len = 0;
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
        const double dx = line[i + 1].x - line[i].x, dy = line[i + 1].y - line[i].y;
        len += std::sqrt(dx * dx + dy * dy);  // not std::hypot: sqrt is exactly rounded
    }
    return len;
}

// Main river in band [vLow, vLow + band]: from the west margin to the east margin.
bool walkMainRiver(Rng& rng, const RiverPlan& plan, double vLow, double omegaScale,
                   SegmentIndex& index, int id, RiverLine& line) {
    const double vCentre = vLow + 0.5 * plan.band;
    const double belt = 0.3 * plan.band;  // target half width of the meander belt
    const MeanderStyle style{kMinWavelength,
                             std::max(kMinWavelength, std::min(1.3 * plan.band, 120.0)),
                             0.5,
                             1.25,
                             0.3,
                             1.5,
                             1.95};
    Walker walker{rng, style, omegaScale};
    line.clear();
    const std::size_t start = index.mark();
    XY p{kMargin + 1.0, vCentre + rng.uniform(-0.2, 0.2) * belt};
    line.push_back(p);
    const double uEnd = plan.width - kMargin - 1.0;
    const auto skip = [id](const Seg& s) {
        return [id, &s](const Seg& o) { return o.line == id && std::abs(o.index - s.index) <= 1; };
    };

    // Half wave by half wave. A half wave that leaves the band or comes too close to a river is
    // undone and redrawn calmer (the last try straight), so that one tight bend in the wrong
    // place does not cost the whole river its meanders.
    const std::size_t maxVertices = static_cast<std::size_t>(plan.width) * 40;
    while (p.x < uEnd) {
        if (line.size() > maxVertices) {  // not getting anywhere: give up this river
            index.rollback(start);
            return false;
        }
        const std::size_t vertices = line.size(), segments = index.mark();
        const double phase = walker.phase;
        bool ok = false;
        for (int attempt = 0; attempt < 5 && !ok; ++attempt) {
            line.resize(vertices);
            index.rollback(segments);
            walker.phase = phase;
            p = line.back();
            walker.beginHalfWave(attempt == 4 ? 0.0 : 1.0 - 0.25 * attempt);
            const double end = (std::floor(phase / kPi + 1e-9) + 1.0) * kPi;
            ok = true;
            while (ok && walker.phase < end && p.x < uEnd) {
                // Pull towards the band centre, saturating, so that drift from unequal half
                // waves does not accumulate.
                const double pull = -0.35 * std::clamp((p.y - vCentre) / belt, -1.5, 1.5);
                const XY q = walker.step(p, pull, rng.uniform(0.5, 1.0));
                const Seg s{p, q, id, static_cast<int>(line.size()) - 1};
                ok = insideBox(q, kMargin, plan.width - kMargin, vLow + 0.1 * plan.band,
                               vLow + 0.9 * plan.band) &&
                     index.tryAdd(s, skip(s));
                if (ok) {
                    line.push_back(q);
                    p = q;
                }
            }
        }
        if (!ok) {
            index.rollback(start);
            return false;
        }
    }
    return true;
}

// Tributary leaving main river `main` at vertex `j` towards side (+1 north, -1 south), returned
// in flow order: it ends at the junction.
bool walkTributary(Rng& rng, const RiverPlan& plan, double vLow, const RiverLine& main,
                   std::size_t j, int side, RiverLine& line) {
    MeanderStyle style{10, 28, 0.15, 0.8, 0.0, 0.0, 0.0};
    Walker walker{rng, style, 1.0};
    const double base = side * kHalfPi + rng.uniform(-0.6, 0.6);
    const double length = std::max(4.0, rng.uniform(0.2, 0.44) * plan.band);
    line.clear();
    XY p = main[j];
    line.push_back(p);
    double walked = 0;
    while (walked < length) {
        const double ds = rng.uniform(0.5, 1.0);
        const XY q = walker.stepAuto(p, base, ds);
        if (!insideBox(q, kMargin, plan.width - kMargin, vLow + 0.04 * plan.band,
                       vLow + 0.96 * plan.band)) {
            break;
        }
        p = q;
        line.push_back(p);
        walked += ds;
    }
    if (line.size() < 4) return false;
    // The junction angle: the tributary's last segment must leave both main segments at the
    // junction by a clear angle (no near-overlap that clearance checks would not see).
    const XY& a = line[1];
    const XY& jp = main[j];
    for (const XY& m : {main[j - 1], main[j + 1]}) {
        const double ax = a.x - jp.x, ay = a.y - jp.y, bx = m.x - jp.x, by = m.y - jp.y;
        const double cosAngle =
            (ax * bx + ay * by) / std::sqrt((ax * ax + ay * ay) * (bx * bx + by * by));
        if (cosAngle > 0.94) return false;  // < ~20 degrees
    }
    std::reverse(line.begin(), line.end());
    return true;
}

void generateRivers(const RiverPlan& plan, std::uint64_t seed, RiverLines& lines, int& mains) {
    lines.clear();
    mains = 0;
    if (plan.mains == 0) return;
    Rng rng(hash64(seed ^ 0x7269766572730000ull));  // "rivers"
    SegmentIndex index(plan.width, plan.height, 4.0, kClearance);

    // Main rivers; a river whose walk gets stuck retries with calmer meanders, the last time with
    // none.
    std::vector<double> bandLow;
    for (int i = 0; i < plan.mains; ++i) {
        const double vLow = kMargin + i * plan.band;
        RiverLine line;
        for (int attempt = 0; attempt < 6; ++attempt) {
            const double omegaScale = attempt == 5 ? 0.0 : 1.0 - 0.18 * attempt;
            const int id = static_cast<int>(lines.size());
            if (walkMainRiver(rng, plan, vLow, omegaScale, index, id, line)) {
                lines.push_back(std::move(line));
                bandLow.push_back(vLow);
                break;
            }
        }
    }
    mains = static_cast<int>(lines.size());

    // Tributaries, at the outer apex of meander bends, a few per main river.
    for (int m = 0; m < mains; ++m) {
        const RiverLine main = lines[m];  // a copy: lines grows below
        const std::size_t n = main.size();
        if (n < 12) continue;
        const int wanted = std::max(1, static_cast<int>(pathLength(main) / 35.0));
        std::vector<std::size_t> used;
        int accepted = 0;
        for (int attempt = 0; attempt < 4 * wanted && accepted < wanted; ++attempt) {
            const int side = rng.chance(0.5) ? 1 : -1;
            std::size_t j = 2 + rng.below(n - 5);  // [2, n - 4]
            while (j + 1 <= n - 3 && side * main[j + 1].y > side * main[j].y)
                ++j;
            while (j - 1 >= 2 && side * main[j - 1].y > side * main[j].y)
                --j;
            const bool near = std::any_of(used.begin(), used.end(), [j](std::size_t u) {
                return (j > u ? j - u : u - j) < 4;
            });
            if (near) continue;
            RiverLine trib;
            if (!walkTributary(rng, plan, bandLow[m], main, j, side, trib)) continue;
            const auto atJunction = [&](const Seg& o) {
                return o.line == m &&
                       (o.index == static_cast<int>(j) - 1 || o.index == static_cast<int>(j));
            };
            const int id = static_cast<int>(lines.size());
            if (!addLine(index, trib, id, atJunction)) continue;
            lines.push_back(std::move(trib));
            used.push_back(j);
            ++accepted;
        }
    }
}

std::size_t riverVertexCount(const RiverLines& lines, int mains) {
    std::size_t n = 0;
    for (const RiverLine& l : lines)
        n += l.size();
    return n - (lines.size() - static_cast<std::size_t>(mains));  // junctions are shared
}

void gridFor(std::size_t demPoints, int& width, int& height) {
    // A 5:4 grid, so that row / column mix-ups cannot hide in tests.
    width = std::max(8, static_cast<int>(std::lround(std::sqrt(demPoints * 1.25))));
    height = std::max(8, static_cast<int>(std::lround(static_cast<double>(demPoints) / width)));
}

}  // namespace

SyntheticData generateSyntheticData(const SyntheticOptions& options) {
    assert(options.cellSize > 0);
    assert(options.roughness > 0 && options.roughness < 1);
    assert(options.targetPoints > 0);
    // The river count depends on the grid, the grid on the river count: a few fixed-point rounds
    // (rivers only, cheap) settle the DEM share of the target.
    const auto target = static_cast<double>(options.targetPoints);
    std::size_t demPoints = options.targetPoints;
    int width = 0, height = 0, mains = 0;
    RiverLines lines;
    for (int round = 0; round < 3; ++round) {
        gridFor(demPoints, width, height);
        generateRivers(planRivers(width, height, options.rivers), options.seed, lines, mains);
        const double rivers = static_cast<double>(riverVertexCount(lines, mains));
        demPoints = static_cast<std::size_t>(std::max(target * 0.5, target - rivers));
    }
    gridFor(demPoints, width, height);
    if (options.width > 0 && options.height > 0) {  // an explicit grid wins over the target
        width = options.width;
        height = options.height;
    }
    generateRivers(planRivers(width, height, options.rivers), options.seed, lines, mains);

    SyntheticData data;
    data.mainRivers = mains;
    DemGrid& dem = data.dem;
    dem.width = width;
    dem.height = height;
    dem.cellX = options.cellSize;
    dem.cellY = -options.cellSize;
    dem.originX = kSyntheticOriginX + 0.5 * options.cellSize;
    dem.originY = kSyntheticOriginY + (height - 0.5) * options.cellSize;
    const std::vector<float> terrain =
        generateTerrain(width, height, options.seed, options.roughness);
    dem.z.assign(terrain.begin(), terrain.end());

    // Cell units -> metres. The junction copies are transformed by the same expression, so they
    // stay bit-identical to the main river vertex they join.
    data.rivers = std::move(lines);
    for (RiverLine& line : data.rivers) {
        for (XY& p : line) {
            p.x = kSyntheticOriginX + p.x * options.cellSize;
            p.y = kSyntheticOriginY + p.y * options.cellSize;
        }
    }
    return data;
}

PointSet generateSyntheticTerrain(const SyntheticOptions& options) {
    const SyntheticData data = generateSyntheticData(options);
    PointSetOptions ps;
    ps.riverClearance = 0.01 * options.cellSize;
    ps.lockBorder = options.lockBorder;
    return buildPointSet(data.dem, data.rivers, ps);
}

// --- Writing ---------------------------------------------------------------------------------

bool writeDemFile(const DemGrid& dem, const OGRSpatialReference& srs, const std::string& path,
                  std::string& error) {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    if (driver == nullptr) {
        error = "'" + path + "': the GTiff driver is not available";
        return false;
    }
    const char* createOptions[] = {"COMPRESS=DEFLATE", "PREDICTOR=3", "TILED=YES", nullptr};
    GDALDatasetUniquePtr ds(driver->Create(path.c_str(), dem.width, dem.height, 1, GDT_Float32,
                                           const_cast<char**>(createOptions)));
    if (!ds) {
        error = "'" + path + "': cannot create" + gdalErrorSuffix();
        return false;
    }
    double gt[6] = {dem.originX - 0.5 * dem.cellX, dem.cellX, 0,
                    dem.originY - 0.5 * dem.cellY, 0,         dem.cellY};
    ds->SetGeoTransform(gt);
    ds->SetSpatialRef(&srs);
    if (ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, dem.width, dem.height,
                                       const_cast<float*>(dem.z.data()), dem.width, dem.height,
                                       GDT_Float32, 0, 0, nullptr) != CE_None) {
        error = "'" + path + "': write failed" + gdalErrorSuffix();
        return false;
    }
    CPLErrorReset();
    ds.reset();  // flushes
    if (CPLGetLastErrorType() >= CE_Failure) {
        error = "'" + path + "': write failed" + gdalErrorSuffix();
        return false;
    }
    return true;
}

namespace {

bool writeRiverFile(const SyntheticData& data, const OGRSpatialReference& srs,
                    const std::string& path, std::string& error) {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GeoJSON");
    if (driver == nullptr) {
        error = "'" + path + "': the GeoJSON driver is not available";
        return false;
    }
    GDALDatasetUniquePtr ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!ds) {
        error = "'" + path + "': cannot create" + gdalErrorSuffix();
        return false;
    }
    // 17 significant digits round-trip doubles exactly: junctions stay shared vertices.
    const char* layerOptions[] = {"SIGNIFICANT_FIGURES=17", "WRITE_NAME=NO", nullptr};
    OGRSpatialReference layerSrs(srs);  // CreateLayer wants a mutable one in GDAL 3.6
    OGRLayer* layer =
        ds->CreateLayer("rivers", &layerSrs, wkbLineString, const_cast<char**>(layerOptions));
    if (layer == nullptr) {
        error = "'" + path + "': cannot create the layer" + gdalErrorSuffix();
        return false;
    }
    OGRFieldDefn id("id", OFTInteger), kind("kind", OFTString);
    layer->CreateField(&id);
    layer->CreateField(&kind);
    for (std::size_t i = 0; i < data.rivers.size(); ++i) {
        OGRFeature feature(layer->GetLayerDefn());
        feature.SetField("id", static_cast<int>(i));
        feature.SetField("kind", static_cast<int>(i) < data.mainRivers ? "main" : "tributary");
        OGRLineString line;
        for (const XY& p : data.rivers[i])
            line.addPoint(p.x, p.y);
        feature.SetGeometry(&line);
        if (layer->CreateFeature(&feature) != OGRERR_NONE) {
            error = "'" + path + "': write failed" + gdalErrorSuffix();
            return false;
        }
    }
    CPLErrorReset();
    ds.reset();
    if (CPLGetLastErrorType() >= CE_Failure) {
        error = "'" + path + "': write failed" + gdalErrorSuffix();
        return false;
    }
    return true;
}

}  // namespace

bool writeSyntheticData(const SyntheticData& data, const std::string& dir, std::string& error,
                        bool replace) {
    namespace fs = std::filesystem;
    QuietGdalErrors quiet;
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) {
        error = "'" + dir + "': cannot create the directory: " + ec.message();
        return false;
    }
    const std::string demPath = (fs::path(dir) / "dem.tif").string();
    const std::string riverPath = (fs::path(dir) / "rivers.geojson").string();

    OGRSpatialReference srs;
    if (srs.importFromEPSG(kSyntheticEpsg) != OGRERR_NONE) {
        error = "EPSG:" + std::to_string(kSyntheticEpsg) + ": unknown CRS" + gdalErrorSuffix();
        return false;
    }
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    // GDAL writes the temporaries by name; AtomicFile checks, syncs and moves them into place
    // (replacing the files of an earlier run only when `replace`).
    const format::OutputOptions output{.replace = replace, .inputs = {}, .inputParts = {}};
    format::AtomicFile demFile, riverFile;
    return demFile.openByName(demPath, output, error) &&
           riverFile.openByName(riverPath, output, error) &&
           writeDemFile(data.dem, srs, demFile.tempPath(), error) &&
           writeRiverFile(data, srs, riverFile.tempPath(), error) && demFile.commit(error) &&
           riverFile.commit(error);
}

}  // namespace unilod
