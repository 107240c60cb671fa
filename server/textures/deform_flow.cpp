// The flow solve of CAW20 (G. Guingo, F. Larue, B. Sauvage, N. Lutz, J.-M. Dischler, M.-P. Cani,
// "Content-aware texture deformation with dynamic control", Computers & Graphics 91, 2020, sec. 4):
// min |D v - R_dual|^2 (eq. 6) over the free texels by CGLS from v = 0, which gives the minimum-norm
// least-squares solution; the scalars on the host in double, the vectors on the device in `real`.
#include "textures/deform_flow.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "common/fnv1a.h"

namespace squall::textures {
namespace {

uint64_t key_hash(const DeformSpec& s) {
  uint64_t h = kFnv1aOffsetBasis;
  const int64_t sizes[] = {s.width, s.height, s.max_iterations};
  h = fnv1a(h, sizes, sizeof(sizes));
  h = fnv1a(h, &s.tolerance, sizeof(s.tolerance));
  h = fnv1a(h, s.rigidity.data(), s.rigidity.size() * sizeof(float));
  return fnv1a(h, s.chart.data(), s.chart.size());
}

// A double split in two floats, hi + lo, so that a float kernel argument carries it to a double kernel.
cl_float2 split(double a) {
  const float hi = float(a);
  return cl_float2{{hi, float(a - double(hi))}};
}

size_t chunks(int n) { return size_t(n + kDeformChunk - 1) / kDeformChunk; }

// CGLS (conjugate gradients on the normal equations D^T D v = D^T b) on one grid.
class Cgls {
 public:
  Cgls(Runtime& runtime, DeformKernels& kernels, const DeformSpec& spec)
      : runtime_(runtime),
        k_(kernels),
        w_(spec.width),
        h_(spec.height),
        texels_(w_ * h_),
        cells_((w_ - 1) * (h_ - 1)),
        real_(kernels.real_size),
        free_(free_texels(w_, h_, spec.chart)),
        b_(dual_rigidity(w_, h_, spec.rigidity)) {
    auto buffer = [&](size_t reals) { return cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, reals * real_); };
    free_buffer_ = cl::Buffer(runtime_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, free_.size(), free_.data());
    r_ = buffer(cells_);
    q_ = buffer(cells_);
    x_ = buffer(2 * texels_);
    s_ = buffer(2 * texels_);
    p_ = buffer(2 * texels_);
    x_best_ = buffer(2 * texels_);
    partial_d_ = buffer(chunks(w_ - 1) * (h_ - 1));
    partial_t_ = buffer(chunks(w_) * h_);
  }

  // x from 0 until |D^T r| <= tolerance |D^T b| or max_iterations; then the true residual of x. Asks
  // `cancel` before each iteration.
  FlowSolve run(double tolerance, int max_iterations, const Cancellation& cancel) {
    FlowSolve out;
    zero(x_, 2 * texels_);
    write_b();
    double gamma = apply_dt();  // s = D^T b
    const double gamma0 = gamma;
    if (gamma0 == 0) return out;  // D^T b = 0: v = 0 solves the normal equations
    copy(s_, p_, 2 * texels_);
    while (out.iterations < max_iterations) {
      cancel.check("the deformation's flow solve");
      const double qq = apply_d(p_);  // q = D p
      if (qq == 0) break;
      const double alpha = gamma / qq;
      axpy(x_, p_, alpha, 2 * texels_);
      axpy(r_, q_, -alpha, cells_);
      const double next = apply_dt();
      ++out.iterations;
      if (std::sqrt(next / gamma0) <= tolerance || at_precision_floor(std::sqrt(next / gamma0))) break;
      xpby(p_, s_, next / gamma, 2 * texels_);
      gamma = next;
    }
    out.residual = true_residual(gamma0);
    return out;
  }

  // Near the rounding floor of `real` (float: about 1e-6) CG loses orthogonality and its residual grows
  // without bound: the best iterate there is kept, and brought back once the residual is 10 times worse.
  bool at_precision_floor(double residual) {
    const double floor =
        1e3 * (real_ == 8 ? std::numeric_limits<double>::epsilon() : double(std::numeric_limits<float>::epsilon()));
    if (best_ > 0 && residual > 10 * best_) {
      copy(x_best_, x_, 2 * texels_);
      return true;
    }
    if (residual < floor && (best_ == 0 || residual < best_)) {
      best_ = residual;
      copy(x_, x_best_, 2 * texels_);
    }
    return false;
  }

  // x as float2 per texel into `flow`.
  void store(const cl::Buffer& flow) {
    auto lock = runtime_.exclusive();
    k_.flow_store.launch(cl::NDRange(texels_), cl::NullRange, x_, flow, cl_int(texels_));
  }

 private:
  // |D^T (b - D x)| / |D^T b|, b - D x recomputed from x.
  double true_residual(double gamma0) {
    apply_d(x_);
    write_b();
    axpy(r_, q_, -1, cells_);
    return std::sqrt(apply_dt() / gamma0);
  }

  void write_b() {
    std::vector<unsigned char> bytes = as_real(b_);
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(r_, CL_TRUE, 0, bytes.size(), bytes.data());
  }

  std::vector<unsigned char> as_real(const std::vector<double>& values) const {
    std::vector<unsigned char> bytes(values.size() * real_);
    for (size_t k = 0; k < values.size(); ++k) {
      if (real_ == 8) {
        std::memcpy(&bytes[k * 8], &values[k], 8);
      } else {
        const float f = float(values[k]);
        std::memcpy(&bytes[k * 4], &f, 4);
      }
    }
    return bytes;
  }

  // The sum of `count` reals of a partial-sums buffer, in double.
  double sum(const cl::Buffer& partial, size_t count) {
    std::vector<unsigned char> bytes(count * real_);
    runtime_.queue().enqueueReadBuffer(partial, CL_TRUE, 0, bytes.size(), bytes.data());
    double total = 0;
    for (size_t k = 0; k < count; ++k) {
      if (real_ == 8) {
        double d;
        std::memcpy(&d, &bytes[k * 8], 8);
        total += d;
      } else {
        float f;
        std::memcpy(&f, &bytes[k * 4], 4);
        total += f;
      }
    }
    return total;
  }

  double apply_d(const cl::Buffer& p) {  // q = D p; returns |q|^2
    auto lock = runtime_.exclusive();
    k_.cgls_d.launch(cl::NDRange(chunks(w_ - 1), h_ - 1), cl::NullRange, p, q_, cl_int(w_), cl_int(h_), partial_d_);
    return sum(partial_d_, chunks(w_ - 1) * (h_ - 1));
  }

  double apply_dt() {  // s = D^T r, masked; returns |s|^2
    auto lock = runtime_.exclusive();
    k_.cgls_dt.launch(cl::NDRange(chunks(w_), h_), cl::NullRange, r_, free_buffer_, s_, cl_int(w_), cl_int(h_),
                      partial_t_);
    return sum(partial_t_, chunks(w_) * h_);
  }

  void axpy(const cl::Buffer& y, const cl::Buffer& x, double a, size_t n) {
    auto lock = runtime_.exclusive();
    k_.cgls_axpy.launch(cl::NDRange(n), cl::NullRange, y, x, split(a), cl_int(n));
  }

  void xpby(const cl::Buffer& p, const cl::Buffer& s, double b, size_t n) {
    auto lock = runtime_.exclusive();
    k_.cgls_xpby.launch(cl::NDRange(n), cl::NullRange, p, s, split(b), cl_int(n));
  }

  void zero(const cl::Buffer& buffer, size_t reals) {
    std::vector<unsigned char> bytes(reals * real_, 0);
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueWriteBuffer(buffer, CL_TRUE, 0, bytes.size(), bytes.data());
  }

  void copy(const cl::Buffer& from, const cl::Buffer& to, size_t reals) {
    auto lock = runtime_.exclusive();
    runtime_.queue().enqueueCopyBuffer(from, to, 0, 0, reals * real_);
  }

  Runtime& runtime_;
  DeformKernels& k_;
  const int w_, h_;
  const size_t texels_, cells_;
  const size_t real_;
  std::vector<uint8_t> free_;
  std::vector<double> b_;
  double best_ = 0;  // the smallest residual below the rounding floor (0: none yet)
  // Device vectors (`real`): r, q per dual cell; x, s, p, x_best real2 per texel; partial sums per chunk.
  cl::Buffer free_buffer_, r_, q_, x_, s_, p_, x_best_, partial_d_, partial_t_;
};

}  // namespace

std::vector<uint8_t> free_texels(int width, int height, const std::vector<uint8_t>& chart) {
  auto inside = [&](int i, int j) { return chart.empty() || chart[size_t(i) + size_t(width) * j] != 0; };
  std::vector<uint8_t> out(size_t(width) * height, 0);
  for (int j = 1; j < height - 1; ++j)
    for (int i = 1; i < width - 1; ++i)
      out[size_t(i) + size_t(width) * j] =
          inside(i, j) && inside(i - 1, j) && inside(i + 1, j) && inside(i, j - 1) && inside(i, j + 1);
  return out;
}

std::vector<double> dual_rigidity(int width, int height, const std::vector<float>& rigidity) {
  std::vector<double> out(size_t(width - 1) * (height - 1));
  auto r = [&](int i, int j) { return double(rigidity[size_t(i) + size_t(width) * j]); };
  for (int j = 0; j < height - 1; ++j)
    for (int i = 0; i < width - 1; ++i)
      out[size_t(i) + size_t(width - 1) * j] = 0.25 * (r(i, j) + r(i + 1, j) + r(i, j + 1) + r(i + 1, j + 1));
  return out;
}

std::shared_ptr<const FlowField> solve_flow(Runtime& runtime, DeformKernels& kernels, const DeformSpec& spec,
                                            const Cancellation& cancel) {
  auto flow = std::make_shared<FlowField>();
  flow->width = spec.width;
  flow->height = spec.height;
  flow->buffer = cl::Buffer(runtime.context(), CL_MEM_READ_WRITE, flow->bytes());
  Cgls cgls(runtime, kernels, spec);
  flow->solve = cgls.run(spec.tolerance, spec.max_iterations, cancel);
  cgls.store(flow->buffer);
  flow->v.resize(size_t(spec.width) * spec.height * 2);
  auto lock = runtime.exclusive();
  runtime.queue().enqueueReadBuffer(flow->buffer, CL_TRUE, 0, flow->bytes(), flow->v.data());
  return flow;
}

bool FlowCache::matches(const Entry& e, uint64_t hash, const DeformSpec& s) const {
  return e.hash == hash && e.width == s.width && e.height == s.height && e.max_iterations == s.max_iterations &&
         e.tolerance == s.tolerance && e.rigidity == s.rigidity && e.chart == s.chart;
}

std::shared_ptr<const FlowField> FlowCache::find(const DeformSpec& spec) {
  const uint64_t hash = key_hash(spec);
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = entries_.begin(); it != entries_.end(); ++it) {
    if (!matches(*it, hash, spec)) continue;
    entries_.splice(entries_.begin(), entries_, it);
    return entries_.front().flow;
  }
  return nullptr;
}

FlowCache::FlowCache(LimitGate* gate) : gate_(gate) {
  if (gate_) gate_->add_reclaimer(this);
}

FlowCache::~FlowCache() {
  if (gate_) gate_->remove_reclaimer(this);
}

void FlowCache::keep(const DeformSpec& spec, std::shared_ptr<const FlowField> flow, Slot* reserved) {
  const uint64_t hash = key_hash(spec);
  // The flow twice (host and device), the rigidity and the chart.
  const uint64_t bytes = 2 * flow->bytes() + spec.rigidity.size() * sizeof(float) + spec.chart.size();
  std::lock_guard<std::mutex> lock(mutex_);
  for (const Entry& e : entries_)
    if (matches(e, hash, spec)) return;
  if (entries_.size() >= kEntries) {
    auto unused = oldest_unused();
    if (unused == entries_.end()) return;  // all in use: served, not kept, still counted where it was
    entries_.erase(unused);
  }
  Slot memory = reserved && gate_ ? gate_->cache_from(*reserved, bytes) : Slot();
  while (gate_ && memory.amount() == 0) {
    try {
      memory = gate_->acquire_cache_memory("a deformation's flow field kept for the next streams", bytes);
      break;
    } catch (const Error&) {
      auto unused = oldest_unused();
      if (unused == entries_.end()) return;  // no room: served, not kept
      entries_.erase(unused);
    }
  }
  entries_.push_front({hash, spec.width, spec.height, spec.max_iterations, spec.tolerance, spec.rigidity, spec.chart,
                       std::move(flow), bytes, std::move(memory)});
}

// Entries erased give their budget back at once: the flow's memory, host and device, goes with the last
// deformation that uses it, and one in use is not erased.
uint64_t FlowCache::reclaim(uint64_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (uint64_t freed = 0; freed < bytes;) {
    auto unused = oldest_unused();
    if (unused == entries_.end()) break;
    freed += unused->bytes;
    entries_.erase(unused);
  }
  return 0;
}

std::list<FlowCache::Entry>::iterator FlowCache::oldest_unused() {
  for (auto it = entries_.end(); it != entries_.begin();) {
    --it;
    if (it->flow.use_count() == 1) return it;
  }
  return entries_.end();
}

}  // namespace squall::textures
