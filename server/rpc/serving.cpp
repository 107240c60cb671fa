#include "rpc/serving.h"

#include "common/error.h"

namespace squall::rpc {

void ServingState::require_serving() const {
  switch (phase_.load()) {
    case Phase::Serving: return;
    case Phase::Starting:
      fail(Code::Unavailable, "squalld is still building its kernels; retry when health is SERVING");
    case Phase::Draining: fail(Code::Unavailable, "squalld is shutting down; retry on another replica");
  }
}

}  // namespace squall::rpc
