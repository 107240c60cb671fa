#include "textures/lagrangian.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "runtime/host_transfer.h"
#include "runtime/slices.h"
#include "textures/grid_quality.h"
#include "textures/poisson.h"
#include "textures/state_codec.h"

namespace squall::textures {
namespace {

constexpr int kTile = 16;                    // pixels per reconstruction tile side
constexpr size_t kVertexGroup = 64;          // vertices per work-group of the advection
constexpr double kFirstAdvectGroups = 1024;  // work-groups of the advection's first slice
constexpr uint32_t kStateVersion = 1;
constexpr double kAlive = std::numeric_limits<double>::infinity();

struct Particle {
  uint64_t id = 0;
  double birth = 0;      // s
  double kill = kAlive;  // s; finite once FADING
  bool fading() const { return kill != kAlive; }
};

// floor(v) as an index into [0, n): clamped in double first, so a value far outside (or NaN, which goes to 0)
// is never converted to int.
int clamped_index(double v, int n) {
  v = std::floor(v);
  return v >= n - 1 ? n - 1 : v > 0 ? int(v) : 0;
}

// The reconstruction tiles [i0, i1] x [j0, j1] that a grid's bounds meet; none (i0 > i1) off the output.
struct TileRange {
  int i0 = 1, i1 = 0, j0 = 0, j1 = 0;
  size_t count() const { return i0 > i1 ? 0 : size_t(i1 - i0 + 1) * size_t(j1 - j0 + 1); }
};

int tile_rows(const OutputGrid& out) { return (out.height + kTile - 1) / kTile; }

TileRange tiles_met(const OutputGrid& out, const cl_float4& box) {
  const int tiles_y = tile_rows(out);
  auto tile_of = [](float x, float origin, float pixel, int count) {
    return clamped_index((x - origin) / pixel / kTile, count);
  };
  if (box.s[2] < out.x0 || box.s[3] < out.y0 || box.s[0] > out.x0 + out.width * out.pixel_x ||
      box.s[1] > out.y0 + out.height * out.pixel_y)
    return {};
  return {tile_of(box.s[0], out.x0, out.pixel_x, out.tiles_x), tile_of(box.s[2], out.x0, out.pixel_x, out.tiles_x),
          tile_of(box.s[1], out.y0, out.pixel_y, tiles_y), tile_of(box.s[3], out.y0, out.pixel_y, tiles_y)};
}

double milliseconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// The per-frame arrays the reconstruction reads, built on the host.
struct Reconstruction {
  std::vector<float> weights;    // one per vertex
  std::vector<cl_float4> boxes;  // per grid: its bounds (xmin, ymin, xmax, ymax; du), its buckets' inverse size
  std::vector<cl_int> bucket_offsets{0};         // per grid, its buckets' quads, CSR (push_buckets)
  std::vector<cl_uchar> bucket_quads;            // by first vertex: a + G b < 256 for G <= 16
  std::vector<cl_int> tile_offsets, tile_grids;  // grids per tile, CSR, in grid order
};

class Lagrangian final : public Advection {
 public:
  Lagrangian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
             std::shared_ptr<const DeviceInputs> inputs, std::string_view state, const Cancellation& cancel)
      : runtime_(runtime),
        kernels_(kernels),
        params_(spec.lagrangian),
        scale_(spec.texture.scale),
        t0_(spec.t0),
        dt_(spec.dt),
        substeps_(spec.substeps),
        inputs_(std::move(inputs)),
        angle_rng_(spec.seed, RngPurpose::PoissonAngle),
        patch_rng_(spec.seed, RngPurpose::PatchOrigin),
        time_(spec.t0),
        cancel_(cancel) {
    const double d = params_.d;
    region_ = {spec.output.x0 - d, spec.output.y0 - d, spec.output.x1 + d, spec.output.y1 + d, {}};
    held_limit_ = lagrangian_grid_bound(spec);
    tile_budget_ = lagrangian_tile_bound(spec.lagrangian, spec.output);
    sample_fluid_of_inputs();
    if (!state.empty()) restore(state);
  }

  TextureFrame next() override {
    cancel_.check("the advection");
    ParticleStats stats;
    std::vector<std::pair<std::string, double>> stages;
    if (!started_) {
      started_ = true;
      auto start = std::chrono::steady_clock::now();
      insert(stats, t0_ - params_.fade_tau);  // born one fade earlier: frame 0 shows them at full weight
      stages.emplace_back("maintain", milliseconds_since(start));
    } else {
      auto start = std::chrono::steady_clock::now();
      advect();
      stages.emplace_back("advect", milliseconds_since(start));
      start = std::chrono::steady_clock::now();
      ++index_;
      time_ = t0_ + index_ * dt_;
      maintain(stats);
      stages.emplace_back("maintain", milliseconds_since(start));
    }
    auto start = std::chrono::steady_clock::now();
    TextureFrame frame = reconstruct(stats);
    stages.emplace_back("reconstruct", milliseconds_since(start));
    frame.stats.stage_ms = std::move(stages);
    return frame;
  }

  void steer(std::shared_ptr<const DeviceInputs> inputs, double dt, int substeps) override {
    inputs_ = std::move(inputs);
    sample_fluid_of_inputs();
    t0_ = time_ - index_ * dt;  // keeps time_ = t0_ + index_ dt_
    dt_ = dt;
    substeps_ = substeps;
  }

  const DeviceInputs& inputs() const override { return *inputs_; }
  double time() const override { return time_; }

  std::string checkpoint() const override {
    StateWriter out;
    out.put(kStateVersion);
    out.put(started_);
    out.put(int64_t(index_));
    out.put(counter_);
    out.put(next_id_);
    out.put(uint64_t(particles_.size()));  // then each particle's members, in order
    for (const Particle& p : particles_) {
      out.put(p.id);
      out.put(p.birth);
      out.put(p.kill);
    }
    out.put_vector(positions_);
    out.put_vector(uvs_);
    return out.take();
  }

 private:
  // Poisson sampling covers the fluid of the current inputs.
  void sample_fluid_of_inputs() {
    region_.inside = [in = inputs_](double x, double y) { return in->fluid(x, y); };
  }

  int res() const { return params_.grid_res; }
  size_t vertices() const { return size_t(res()) * res(); }
  double spacing() const { return (2 + params_.beta) * params_.d / (res() - 1); }  // sec. 3.3.1
  GridView grid(size_t k) const { return {positions_.data() + 2 * k * vertices(), res(), spacing()}; }

  Vec2 centre(size_t k) const {  // the centre of mass of the grid's vertices (sec. 3.3.2)
    double x = 0, y = 0;
    for (size_t v = 0; v < vertices(); ++v) {
      x += positions_[2 * (k * vertices() + v)];
      y += positions_[2 * (k * vertices() + v) + 1];
    }
    return {x / vertices(), y / vertices()};
  }

  std::vector<uint8_t> outside(size_t k) const {
    std::vector<uint8_t> flags(vertices());
    GridView g = grid(k);
    for (int b = 0; b < res(); ++b)
      for (int a = 0; a < res(); ++a) flags[a + res() * b] = !inputs_->fluid(g.vertex(a, b).x, g.vertex(a, b).y);
    return flags;
  }

  void restore(std::string_view state) {
    StateReader in(state);
    if (in.get<uint32_t>("the version") != kStateVersion)
      fail(Code::InvalidArgument, "resume_state has an unknown version");
    started_ = in.get<bool>("started");
    index_ = in.frame_index(kMaxTextureFrames);
    time_ = t0_ + index_ * dt_;
    counter_ = in.get<uint64_t>("the particle counter");
    next_id_ = in.get<uint64_t>("the next particle id");
    // One by one: a count past the end is caught at the first particle missing, before the rest is allocated.
    // More than the advection ever holds (held_limit_, which its memory estimate counts) is no checkpoint of it.
    particles_.clear();
    const uint64_t n = in.get<uint64_t>("the particle count");
    if (n > held_limit_)
      fail(Code::InvalidArgument, "resume_state holds " + std::to_string(n) + " particles, past the " +
                                      std::to_string(held_limit_) +
                                      " this request's output region holds at most: not a checkpoint of this request");
    for (uint64_t i = 0; i < n; ++i) {
      Particle& p = particles_.emplace_back();
      p.id = in.get<uint64_t>("a particle's id");
      p.birth = in.get<double>("a particle's birth time");
      p.kill = in.get<double>("a particle's kill time");
      // Born and killed by the frame's time (insert(), kill_distorted(), kill_crowded()): a later time would
      // have a negative age and weight.
      if (!(std::isfinite(p.birth) && p.birth <= time_ &&
            (p.kill == kAlive || (std::isfinite(p.kill) && p.kill <= time_))))
        fail(Code::InvalidArgument, "resume_state holds a particle born at " + validate::number(p.birth) +
                                        " s and killed at " + validate::number(p.kill) + " s, past its frame's time " +
                                        validate::number(time_) + " s: not a checkpoint of this request");
    }
    positions_ = in.get_finite_vector<float>("the positions", kMaxStateValue);
    uvs_ = in.get_finite_vector<float>("the uvs", kMaxStateValue);
    if (!in.done() || positions_.size() != particles_.size() * 2 * vertices() || uvs_.size() != positions_.size())
      fail(Code::InvalidArgument, "resume_state does not match this request's grid_res");
    if (!started_ && !particles_.empty())  // the first frame inserts the first particles
      fail(Code::InvalidArgument, "resume_state holds particles before its first frame: not a checkpoint");
    // Checked before any tile list is made: grids spread far past the budget would take hours and gigabytes.
    const std::vector<size_t> entries = tile_entries();
    if (const size_t total = std::accumulate(entries.begin(), entries.end(), size_t(0)); total > tile_budget_)
      fail(Code::InvalidArgument, "resume_state's grids meet " + std::to_string(total) +
                                      " reconstruction tiles in all, past the " + std::to_string(tile_budget_) +
                                      " this request's grids ever meet: not a checkpoint of this request");
  }

  // The reconstruction tiles each grid meets.
  std::vector<size_t> tile_entries() const {
    const OutputGrid out = inputs_->output(kTile);
    std::vector<size_t> entries(particles_.size());
    for (size_t k = 0; k < particles_.size(); ++k) entries[k] = tiles_met(out, bounds(k)).count();
    return entries;
  }

  // Carries every vertex over [time_, time_ + dt] on the device, in slices of work-groups that a cancel
  // stops between (millions of vertices of many substeps take a CPU device seconds).
  void advect() {
    if (positions_.empty()) return;
    const size_t bytes = positions_.size() * sizeof(float), count = positions_.size() / 2;
    cl::Buffer buffer(runtime_.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, bytes, positions_.data());
    // A fixed work-group size: with the device's choice, which follows the vertex count, PoCL compiles the
    // kernel again for each new count (about 0.2 s on the CPU). The last slice's ids past count are skipped.
    const SlicePlan plan{(count + kVertexGroup - 1) / kVertexGroup, kVertexGroup, [](size_t) { return 1.0; },
                         kFirstAdvectGroups, WorkKind{"textures.lagrangian_advect", count * size_t(substeps_)}};
    QueueLease lease;
    run_sliced(runtime_, lease, plan, cancel_, "the advection", [&](size_t first, size_t n) {
      kernels_.lagrangian_advect.launch_region(cl::NDRange(first), cl::NDRange(n), cl::NDRange(kVertexGroup), buffer,
                                               cl_int(count), inputs_->velocity(time_, dt_), inputs_->grid(),
                                               cl_float(dt_), cl_int(substeps_));
    });
    runtime_.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, bytes, positions_.data());
  }

  // Kills, deletes and inserts particles at time_ (sec. 3.3.1-3.3.4).
  void maintain(ParticleStats& stats) {
    std::vector<Vec2> centres(particles_.size());
    for (size_t k = 0; k < particles_.size(); ++k) centres[k] = centre(k);
    kill_distorted(centres, stats);
    kill_crowded(centres, stats);
    erase_finished(stats);
    insert(stats, time_);
    fit_tile_budget(stats);
  }

  // Rules 1-3: the grid no longer covers its kernel, some vertex quality fell below 1/2, or it folded.
  void kill_distorted(const std::vector<Vec2>& centres, ParticleStats& stats) {
    for (size_t k = 0; k < particles_.size(); ++k) {
      if (particles_[k].fading()) continue;
      GridQuality q = grid_quality(grid(k), params_.delta_max, outside(k));
      int* rule = !covers_kernel(grid(k), centres[k], params_.d) ? &stats.killed_coverage
                  : q.min_quality < 0.5                          ? &stats.killed_quality
                  : q.folded                                     ? &stats.killed_fold
                                                                 : nullptr;
      if (rule) {
        ++*rule;
        particles_[k].kill = time_;
      }
    }
  }

  // Rule 4: ALIVE particles closer than (1 - alpha) d to an older one (oldest first, ties by id).
  void kill_crowded(const std::vector<Vec2>& centres, ParticleStats& stats) {
    std::vector<size_t> alive;
    for (size_t k = 0; k < particles_.size(); ++k)
      if (!particles_[k].fading()) alive.push_back(k);
    std::stable_sort(alive.begin(), alive.end(),
                     [&](size_t a, size_t b) { return particles_[a].birth < particles_[b].birth; });
    std::vector<Vec2> points;
    for (size_t k : alive) points.push_back(centres[k]);
    for (size_t i : poisson_cull(points, (1 - params_.alpha) * params_.d)) {
      particles_[alive[i]].kill = time_;
      ++stats.killed_density;
    }
  }

  // Deletes particles faded out and those whose grid left the sampled region.
  void erase_finished(ParticleStats& stats) {
    erase_where(stats, [&](size_t k) {
      const Particle& p = particles_[k];
      return (p.fading() && time_ - p.kill >= params_.fade_tau) || !overlaps_region(k);
    });
  }

  // Deletes grids until the frame's tile lists fit tile_budget_: FADING ones before ALIVE ones, each kind the
  // most spread (the most tiles met) first, ties by order.
  void fit_tile_budget(ParticleStats& stats) {
    const std::vector<size_t> entries = tile_entries();
    size_t sum = std::accumulate(entries.begin(), entries.end(), size_t(0));
    if (sum <= tile_budget_) return;
    std::vector<size_t> order(particles_.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      const bool fading_a = particles_[a].fading(), fading_b = particles_[b].fading();
      return fading_a != fading_b ? fading_a : entries[a] > entries[b];
    });
    std::vector<bool> doomed(particles_.size(), false);
    for (size_t i = 0; i < order.size() && sum > tile_budget_; ++i) {
      doomed[order[i]] = true;
      sum -= entries[order[i]];
    }
    erase_where(stats, [&](size_t k) { return doomed[k]; });
  }

  // Deletes the FADING particles killed first until `more` particles fit in held_limit_: with kills in every
  // frame and a long fade_tau the fading ones would otherwise pile up without bound.
  void make_room(size_t more, ParticleStats& stats) {
    if (particles_.size() + more <= held_limit_) return;
    std::vector<size_t> fading;
    for (size_t k = 0; k < particles_.size(); ++k)
      if (particles_[k].fading()) fading.push_back(k);
    std::stable_sort(fading.begin(), fading.end(),
                     [&](size_t a, size_t b) { return particles_[a].kill < particles_[b].kill; });
    fading.resize(std::min(fading.size(), particles_.size() + more - held_limit_));
    std::vector<bool> doomed(particles_.size(), false);
    for (size_t k : fading) doomed[k] = true;
    erase_where(stats, [&](size_t k) { return doomed[k]; });
  }

  // Deletes the particles for which erase(k) holds, keeping the others' order.
  template <typename Predicate>
  void erase_where(ParticleStats& stats, Predicate erase) {
    size_t kept = 0;
    for (size_t k = 0; k < particles_.size(); ++k) {
      const Particle& p = particles_[k];
      if (erase(k)) {
        ++stats.deleted;
        continue;
      }
      if (kept != k) {
        particles_[kept] = p;
        std::copy_n(positions_.begin() + 2 * k * vertices(), 2 * vertices(),
                    positions_.begin() + 2 * kept * vertices());
        std::copy_n(uvs_.begin() + 2 * k * vertices(), 2 * vertices(), uvs_.begin() + 2 * kept * vertices());
      }
      ++kept;
    }
    particles_.resize(kept);
    positions_.resize(2 * kept * vertices());
    uvs_.resize(2 * kept * vertices());
  }

  bool overlaps_region(size_t k) const {
    cl_float4 box = bounds(k);
    return box.s[2] >= region_.x0 && box.s[0] <= region_.x1 && box.s[3] >= region_.y0 && box.s[1] <= region_.y1;
  }

  cl_float4 bounds(size_t k) const { return lattice_bounds(k, 0, 0, res(), res()); }

  // Bounds of vertices (a0 .. a0 + na - 1, b0 .. b0 + nb - 1) of grid k.
  cl_float4 lattice_bounds(size_t k, int a0, int b0, int na, int nb) const {
    const float* xy = positions_.data() + 2 * (k * vertices() + a0 + size_t(res()) * b0);
    cl_float4 box{{xy[0], xy[1], xy[0], xy[1]}};
    for (int b = 0; b < nb; ++b) {
      for (int a = 0; a < na; ++a) {
        const float* v = xy + 2 * (a + size_t(res()) * b);
        box.s[0] = std::min(box.s[0], v[0]);
        box.s[1] = std::min(box.s[1], v[1]);
        box.s[2] = std::max(box.s[2], v[0]);
        box.s[3] = std::max(box.s[3], v[1]);
      }
    }
    return box;
  }

  int buckets() const { return std::min(2 * (res() - 1), 16); }  // per side of a grid's bounds, as in lagrangian.cl

  struct BucketRange {
    int i0, i1, j0, j1;
  };

  // The buckets of a grid with bounds `box` and inverse bucket size `scale` that quad (a, b) of grid k
  // meets, widened by 1e-3 bucket: far more than the float rounding of the bucket the kernel computes.
  BucketRange quad_buckets(size_t k, int a, int b, const cl_float4& box, const cl_float4& scale) const {
    const cl_float4 q = lattice_bounds(k, a, b, 2, 2);
    auto at = [n = buckets()](float x, float origin, float inverse, double widen) {
      return clamped_index((double(x) - origin) * inverse + widen, n);
    };
    return {at(q.s[0], box.s[0], scale.s[0], -1e-3), at(q.s[2], box.s[0], scale.s[0], 1e-3),
            at(q.s[1], box.s[1], scale.s[1], -1e-3), at(q.s[3], box.s[1], scale.s[1], 1e-3)};
  }

  // Grid k's bounds and buckets for lagrangian_reconstruct: buckets() x buckets() over its bounds, each
  // listing (by first vertex, rows b then a ascending, the order of a full scan) the quads whose bounds
  // meet it. A pixel's bucket then lists every quad whose bounds hold it, in scan order: the kernel finds
  // the triangle a full scan would.
  void push_buckets(size_t k, Reconstruction& r) const {
    const int n = buckets();
    const cl_float4 box = bounds(k);
    auto inverse = [n](float lo, float hi) { return hi > lo ? float(n / (double(hi) - lo)) : 0.0f; };
    const cl_float4 scale{{inverse(box.s[0], box.s[2]), inverse(box.s[1], box.s[3]), 0, 0}};
    r.boxes.insert(r.boxes.end(), {box, scale});
    std::vector<BucketRange> ranges;  // per quad, in scan order
    for (int b = 0; b + 1 < res(); ++b)
      for (int a = 0; a + 1 < res(); ++a) ranges.push_back(quad_buckets(k, a, b, box, scale));
    append_buckets(ranges, r);
  }

  // Appends a grid's buckets to r's lists (CSR): in each, the quads of `ranges` meeting it, in order.
  void append_buckets(const std::vector<BucketRange>& ranges, Reconstruction& r) const {
    const int n = buckets(), quads = res() - 1;
    auto each_bucket = [n](const BucketRange& e, auto&& f) {
      for (int j = e.j0; j <= e.j1; ++j)
        for (int i = e.i0; i <= e.i1; ++i) f(i + n * j);
    };
    std::vector<cl_int> start(size_t(n) * n + 1, 0);  // counts, then each bucket's next free slot
    for (const BucketRange& e : ranges) each_bucket(e, [&](int c) { ++start[c + 1]; });
    for (size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
    const cl_int base = cl_int(r.bucket_quads.size());
    for (size_t c = 1; c < start.size(); ++c) r.bucket_offsets.push_back(base + start[c]);
    r.bucket_quads.resize(size_t(base) + start.back());
    for (int q = 0; q < quads * quads; ++q)
      each_bucket(ranges[q],
                  [&](int c) { r.bucket_quads[base + start[c]++] = cl_uchar(q % quads + res() * (q / quads)); });
  }

  // Restores the Poisson-disk distribution around the ALIVE particles with particles born at `birth`.
  void insert(ParticleStats& stats, double birth) {
    std::vector<Vec2> alive;
    for (size_t k = 0; k < particles_.size(); ++k)
      if (!particles_[k].fading()) alive.push_back(centre(k));
    std::vector<Vec2> born = poisson_fill(alive, region_, params_.d, angle_rng_, counter_);
    make_room(born.size(), stats);
    born.resize(std::min(born.size(), held_limit_ - std::min(held_limit_, particles_.size())));  // the ALIVE fill it
    for (Vec2 p : born) {
      add_particle(p, birth);
      ++stats.born;
    }
  }

  // A regular grid centred on p (sec. 3.3.1), mapped to a random patch of R or to u = S x.
  void add_particle(Vec2 p, double birth) {
    Particle particle{next_id_++, birth, kAlive};
    Vec2 u0{scale_ * p.x, scale_ * p.y};
    if (params_.patch_origin == PatchOrigin::Random)
      u0 = {patch_rng_.uniform(2 * particle.id), patch_rng_.uniform(2 * particle.id + 1)};
    const double g = spacing(), half = (res() - 1) / 2.0;
    for (int b = 0; b < res(); ++b) {
      for (int a = 0; a < res(); ++a) {
        double x = p.x + g * (a - half), y = p.y + g * (b - half);
        positions_.insert(positions_.end(), {float(x), float(y)});
        uvs_.insert(uvs_.end(), {float(u0.x + scale_ * (x - p.x)), float(u0.y + scale_ * (y - p.y))});
      }
    }
    particles_.push_back(particle);
  }

  // Vertex weights (eqs. 5-8), grid boxes and tile lists for the frame at time_.
  Reconstruction prepare(const OutputGrid& out, ParticleStats& stats) const {
    Reconstruction r;
    r.weights.resize(particles_.size() * vertices());
    std::vector<TileRange> met(particles_.size());
    for (size_t k = 0; k < particles_.size(); ++k) {
      const Particle& p = particles_[k];
      std::vector<uint8_t> flags = outside(k);
      GridQuality q = grid_quality(grid(k), params_.delta_max, flags);
      double since_kill = p.fading() ? time_ - p.kill : -1;
      double temporal = temporal_weight(time_ - p.birth + dt_, since_kill, params_.fade_tau);  // eq. 6
      vertex_weights(grid(k), centre(k), params_.d, temporal, q.vertex_quality, flags, &r.weights[k * vertices()]);
      p.fading() ? ++stats.fading : ++stats.alive;
      if (!p.fading()) {
        stats.min_quality = std::min(stats.min_quality, q.min_quality);
        stats.max_distortion = std::max(stats.max_distortion, q.max_distortion);
      }
      push_buckets(k, r);
      met[k] = tiles_met(out, r.boxes[2 * k]);
    }
    bin(out, met, r);
    return r;
  }

  // Each tile's grids (those whose bounds meet it, ascending), CSR: counted, then stored. At most
  // tile_budget_ entries (restore, fit_tile_budget), which lagrangian_tile_bound keeps within cl_int.
  static void bin(const OutputGrid& out, const std::vector<TileRange>& met, Reconstruction& r) {
    const size_t tiles = size_t(out.tiles_x) * size_t(tile_rows(out));
    auto each_tile = [&](const TileRange& m, auto&& f) {
      for (int j = m.j0; m.i0 <= m.i1 && j <= m.j1; ++j)
        for (int i = m.i0; i <= m.i1; ++i) f(size_t(i) + size_t(out.tiles_x) * j);
    };
    std::vector<cl_int> start(tiles + 1, 0);  // counts, then each tile's next free slot
    for (const TileRange& m : met) each_tile(m, [&](size_t t) { ++start[t + 1]; });
    for (size_t t = 1; t <= tiles; ++t) start[t] += start[t - 1];
    r.tile_offsets = start;
    r.tile_grids.resize(std::max<size_t>(start.back(), 1), 0);
    for (size_t k = 0; k < met.size(); ++k) each_tile(met[k], [&](size_t t) { r.tile_grids[start[t]++] = cl_int(k); });
  }

  static TileGrid tile_grid(const OutputGrid& out) { return {size_t(out.tiles_x), size_t(tile_rows(out))}; }

  // The reconstruction in slices of tiles (row order), each tile's cost its pixels' scans of the grids it
  // lists; the first slice a row of tiles. A 4096^2 output takes a CPU device seconds: a dropped client or
  // a drain stops it within about a slice.
  static SlicePlan slice_plan(const OutputGrid& out, const Reconstruction& r) {
    const TileGrid tiles = tile_grid(out);
    auto cost = [&r](size_t t) { return 1.0 + (r.tile_offsets[t + 1] - r.tile_offsets[t]); };
    double first = 0, total = 0;
    for (size_t t = 0; t < tiles.x * tiles.y; ++t) {
      total += cost(t);
      if (t < tiles.x) first += cost(t);
    }
    return {tiles.x * tiles.y, 1, cost, first, WorkKind{"textures.lagrangian", size_t(total)}};
  }

  TextureFrame reconstruct(const ParticleStats& counts) {
    ParticleStats stats = counts;
    OutputGrid out = inputs_->output(kTile);
    Reconstruction r = prepare(out, stats);
    TextureSource texture = inputs_->texture(time_);
    TextureFrame frame = empty_frame(index_, time_, out, texture);
    // Copied as they are made: the slices may run on any of the device's queues.
    auto buffer = [&](auto& values) {
      const size_t bytes = values.size() * sizeof(values[0]);
      return bytes == 0 ? cl::Buffer(runtime_.context(), CL_MEM_READ_ONLY, 16)
                        : cl::Buffer(runtime_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, values.data());
    };
    cl::Buffer offsets = buffer(r.tile_offsets), grids = buffer(r.tile_grids), boxes = buffer(r.boxes);
    cl::Buffer bucket_offsets = buffer(r.bucket_offsets), bucket_quads = buffer(r.bucket_quads);
    cl::Buffer positions = buffer(positions_), uvs = buffer(uvs_), weights = buffer(r.weights);
    BufferLease planes = runtime_.buffers().acquire(frame.planes.size() * sizeof(float));  // reused frame to frame
    QueueLease lease;  // one device queue from the first slice to the read-back, but for long frames
    run_sliced(runtime_, lease, slice_plan(out, r), cancel_, "the advection's frame", [&](size_t first, size_t count) {
      // One work-group per tile: its pixels read the same grids (and a size fixed once per output size).
      for (const TileGrid::Rect& t : tile_grid(out).rectangles(first, count))
        kernels_.lagrangian_reconstruct.launch_region(
            cl::NDRange(kTile * t.x, kTile * t.y), cl::NDRange(kTile * t.width, kTile * t.height),
            cl::NDRange(kTile, kTile), planes.buffer(), out, offsets, grids, boxes, bucket_offsets, bucket_quads,
            positions, uvs, weights, cl_int(res()), cl_int(params_.blend == Blend::Normalized ? 1 : 0), texture,
            inputs_->image(), inputs_->scalar(), inputs_->lut(), inputs_->velocity(time_, 0), inputs_->mask());
    });
    read_back(runtime_, planes.buffer(), frame.planes.size() * sizeof(float), frame.planes.data());
    lease.unlock();
    frame.stats = frame_stats(frame);
    frame.stats.particles = stats;
    return frame;
  }

  Runtime& runtime_;
  TextureKernels& kernels_;
  LagrangianParams params_;
  double scale_, t0_, dt_;
  int substeps_;
  std::shared_ptr<const DeviceInputs> inputs_;
  PoissonRegion region_;
  size_t held_limit_;   // particles held at most, ALIVE and FADING: twice the region's area / d^2
  size_t tile_budget_;  // tile list entries held at most (lagrangian_tile_bound)
  CounterRng angle_rng_, patch_rng_;
  // The state a checkpoint holds:
  bool started_ = false;
  int index_ = 0;
  uint64_t counter_ = 0, next_id_ = 0;
  std::vector<Particle> particles_;
  std::vector<float> positions_, uvs_;  // 2 per vertex, grids in particle order
  double time_;
  Cancellation cancel_;  // whether the caller still wants the advection
};

}  // namespace

size_t lagrangian_grid_bound(const LagrangianParams& params, const OutputSpec& output) {
  const double d = params.d;
  return size_t(2 * std::ceil((output.x1 - output.x0 + 2 * d) * (output.y1 - output.y0 + 2 * d) / (d * d)));
}

uint64_t lagrangian_tile_bound(const LagrangianParams& params, const OutputSpec& output) {
  const double rest = (2 + params.beta) * params.d;  // a grid's side at rest (sec. 3.3.1)
  auto across = [rest](double extent, int pixels) {  // the tiles a side of `rest` meets at most
    const int tiles = (pixels + kTile - 1) / kTile;
    return std::min(std::floor(rest / (extent / pixels * kTile)) + 2, double(tiles));
  };
  return uint64_t(kTileSpread * double(lagrangian_grid_bound(params, output)) *
                  across(output.x1 - output.x0, output.width) * across(output.y1 - output.y0, output.height));
}

std::unique_ptr<Advection> make_lagrangian(Runtime& runtime, TextureKernels& kernels, const AdvectSpec& spec,
                                           std::shared_ptr<const DeviceInputs> inputs, std::string_view state,
                                           const Cancellation& cancel) {
  return std::make_unique<Lagrangian>(runtime, kernels, spec, std::move(inputs), state, cancel);
}

}  // namespace squall::textures
