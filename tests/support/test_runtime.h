// The runtime shared by all tests of one binary: the device is chosen and every program compiled once.
#pragma once

#include "fft/fft.h"
#include "runtime/runtime.h"

namespace squall::test {

// --device from $SQUALL_TEST_DEVICE (default "auto"); builds the programs_under_test().
Runtime& runtime();
// RuntimeOptions::host_buffers_on_cpu of runtime(): false under $SQUALL_TEST_BUFFERS=device (the ctest
// runs NAME_device_buffers), where a CPU device's pool buffers are made as a GPU's are.
bool host_buffers_on_cpu();
// The kernel programs this test binary builds: the PROGRAMS prefixes given to squall_test() in
// tests/CMakeLists.txt (all programs when none are given).
std::vector<std::string> programs_under_test();
// The backend the engine tests run on: $SQUALL_TEST_FFT ("vkfft", "clfft" or "fftw"), default vkfft.
std::string engine_fft_backend();
// One plan cache per backend, default the engine tests' backend.
fft::Fft& fft(const std::string& backend = engine_fft_backend());

// Reads back n values of T from a device buffer.
template <typename T>
std::vector<T> read(const cl::Buffer& buffer, size_t n) {
  std::vector<T> out(n);
  runtime().queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * sizeof(T), out.data());
  return out;
}

template <typename T>
cl::Buffer upload(const std::vector<T>& values) {
  return cl::Buffer(runtime().context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, values.size() * sizeof(T),
                    const_cast<T*>(values.data()));
}

}  // namespace squall::test
