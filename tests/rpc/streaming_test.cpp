// StreamCall, the bookkeeping of the streaming handlers, with a writer that records what it is given.
#include "rpc/streaming.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace squall::rpc {
namespace {

struct RecordingWriter {
  std::vector<std::string> written;
  bool accepts = true;
  bool Write(const std::string& message) {
    if (accepts) written.push_back(message);
    return accepts;
  }
};

// A serving squalld's state and a call's context, as a streaming handler has them.
struct Serving {
  ServingState state;
  grpc::ServerContext context;
  explicit Serving(const Limits& limits = {}) : state(limits) { state.set_phase(ServingState::Phase::Serving); }
};

// A message made before squalld began to drain (an eWave step already taken and checkpointed) is sent, and
// the stream then stops with UNAVAILABLE.
TEST(StreamCall, AMessageMadeWhenTheDrainBeginsIsSentAndTheStreamThenStops) {
  Serving serving;
  StreamCall call(serving.context, "Run", serving.state);
  RecordingWriter writer;
  EXPECT_TRUE(call.write(writer, std::string("frame 1")));
  serving.state.set_phase(ServingState::Phase::Draining);
  EXPECT_FALSE(call.write(writer, std::string("frame 2"))) << "the handler stops before its next message";
  EXPECT_TRUE(call.writing()) << "the rest of a message split over several writes is sent";
  EXPECT_EQ(writer.written, (std::vector<std::string>{"frame 1", "frame 2"}));
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::UNAVAILABLE);
}

// A write the transport refuses (the client is gone) ends the call: nothing more is written.
TEST(StreamCall, AFailedWriteEndsTheCall) {
  Serving serving;
  StreamCall call(serving.context, "StreamTiles", serving.state);
  RecordingWriter writer;
  writer.accepts = false;
  EXPECT_FALSE(call.write(writer, std::string("frame 1")));
  EXPECT_FALSE(call.writing());
  writer.accepts = true;
  EXPECT_FALSE(call.write(writer, std::string("frame 2")));
  EXPECT_TRUE(writer.written.empty());
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::CANCELLED);
}

// A stream takes its --max-streams slot before its request is prepared: preparing can bake a river, evaluate
// an ocean or reserve memory, work the slots bound. A refused preparation gives the slot back.
TEST(ServeStream, TheSlotIsTakenBeforeTheRequestIsPrepared) {
  Limits limits;
  limits.max_streams = 1;
  Serving serving(limits);
  bool prepared = false;
  auto prepare = [&] {
    prepared = true;
    fail(Code::InvalidArgument, "request.field is bad");
    return 0;
  };
  auto run = [](StreamCall&, int) {};
  {
    Slot open = serving.state.gate().acquire_stream();
    const grpc::Status full = serve_stream(serving.context, serving.state, "Run", prepare, run);
    EXPECT_EQ(full.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << full.error_message();
    EXPECT_FALSE(prepared) << "prepared for a stream that had no slot";
  }
  const grpc::Status bad = serve_stream(serving.context, serving.state, "Run", prepare, run);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad.error_message();
  EXPECT_TRUE(prepared);
  EXPECT_EQ(serving.state.gate().open_streams(), 0u);
}

}  // namespace
}  // namespace squall::rpc
