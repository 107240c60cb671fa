// Copies between host memory and device buffers that, where they can, queue no command: ReadBack,
// read_views() (which, where it can, copies nothing) and write_buffer().
//
// Where the device computes in its pool buffers' host storage (Runtime::computes_in_host_storage()), the
// host copies the bytes of such a buffer itself, once the queue has finished. PoCL's worker threads take
// the commands of every queue one at a time and are woken for each, so a copy they need not run leaves
// them to the kernels of other requests. Any other copy is a non-blocking command.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "common/float_view.h"
#include "runtime/buffer_pool.h"
#include "runtime/opencl.h"

namespace squall {

class Runtime;

// The host storage of `buffer` where the device computes in it (Runtime::computes_in_host_storage()) and
// it is aligned as the pool's buffers are (kHostAlignment); null elsewhere, where only a command reaches
// the buffer's bytes.
void* computed_host_storage(const Runtime& runtime, const cl::Buffer& buffer);

// Reads of device buffers into host memory, all waited for at once: wait() finishes the queue, then
// copies the bytes of those in host storage; the others are read commands that the same finish waits for.
// Used on the thread that holds the queue (Runtime::exclusive()). An `into` holds its bytes once wait()
// has returned, not before.
//
// Dropped before wait() (an exception), it finishes the queue, so that no read outlives its `into`.
class ReadBack {
 public:
  explicit ReadBack(const Runtime& runtime);  // on the calling thread's queue (Runtime::queue())
  ReadBack(const ReadBack&) = delete;
  ReadBack& operator=(const ReadBack&) = delete;
  ~ReadBack();

  // `bytes` bytes from `offset` in `from` into `into`; Error(Internal) beyond the end of `from`.
  void add(const cl::Buffer& from, size_t offset, size_t bytes, void* into);
  void wait();

  size_t commands() const { return commands_; }  // read commands queued: those not copied by wait()

 private:
  struct Copy {
    const std::byte* from;
    size_t bytes;
    void* into;
  };
  const Runtime& runtime_;
  const cl::CommandQueue& queue_;
  std::vector<Copy> copies_;
  size_t commands_ = 0;
  bool reading_ = false;  // read commands queued and not yet waited for
};

// One read, waited for: a ReadBack of one add().
void read_back(const Runtime& runtime, const cl::Buffer& from, size_t bytes, void* into);

// `count` floats of a buffer from float `offset`.
struct FloatRange {
  size_t offset = 0;
  size_t count = 0;
};

// `ranges` but those of no floats, with each run of ranges that follow one another in the buffer (one's end
// the next one's offset) joined into one: the reads read_views() queues off host storage, one command a run.
std::vector<FloatRange> contiguous_runs(std::span<const FloatRange> ranges);

// The ranges of the buffer `lease` holds as views the caller keeps, once the calling thread's queue has
// finished (the work that wrote them). Where the device computes in the buffer's host storage, the views
// are of that storage and hold the lease: no copy. Elsewhere the ranges are read, one command per
// contiguous run of them, into one pinned block of the runtime's pool (Memory::Pinned), which the views
// hold, and the buffer goes back.
// Error(Internal) for a range past the buffer's end. The views must not outlive the runtime (its pool).
// Off host storage, ranges of no floats at all read nothing and wait for nothing.
std::vector<FloatView> read_views(Runtime& runtime, BufferLease lease, std::span<const FloatRange> ranges);

// Writes `bytes` bytes of `from` at the start of `to` (Error(Internal) beyond its end), on the calling
// thread's queue. Into host storage:
// the queue is finished first (no wait when nothing is queued, as before a request's first kernel), and
// the bytes are in `to` when this returns. Otherwise a non-blocking write command: `from` must stay as it
// is until the queue has run it (its next wait). Returns whether a command was queued.
bool write_buffer(const Runtime& runtime, const cl::Buffer& to, size_t bytes, const void* from);

}  // namespace squall
