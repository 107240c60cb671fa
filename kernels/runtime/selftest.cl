// Small kernels that prove the runtime works end to end (tests, start-up check).

// y <- a x + y, element-wise over n values.
__kernel void axpy(const float a, __global const float* x, __global float* y, const int n) {
  uint i = get_global_id(0);
  if (i < n) y[i] = a * x[i] + y[i];
}

// out <- value, over n values.
__kernel void fill(__global float* out, const float value, const int n) {
  uint i = get_global_id(0);
  if (i < n) out[i] = value;
}

// out[i + nx j] += 1 for the work-item (i, j), with no bounds check: a launch that covers each cell of an
// nx x ny grid exactly once leaves every cell at 1.
__kernel void count_ids(__global float* out, const int nx) {
  size_t i = get_global_id(0), j = get_global_id(1);
  out[i + (size_t)nx * j] += 1.0f;
}
