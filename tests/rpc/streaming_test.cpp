// StreamCall, the bookkeeping of the streaming handlers, with a writer that records what it is given.
#include "rpc/streaming.h"

#include <grpcpp/test/server_context_test_spouse.h>
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
  ASSERT_TRUE(call.live());
  EXPECT_TRUE(call.write(writer, std::string("frame 1")));
  ASSERT_TRUE(call.live());
  serving.state.set_phase(ServingState::Phase::Draining);
  EXPECT_TRUE(call.write(writer, std::string("frame 2"))) << "the rest of a message split over writes is sent";
  EXPECT_FALSE(call.live()) << "the handler stops before its next message";
  EXPECT_EQ(writer.written, (std::vector<std::string>{"frame 1", "frame 2"}));
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::UNAVAILABLE);
}

// A finite stream that sent its every frame ends OK, though squalld began to drain and dropped its token
// after the last one went out: the client has all it asked for.
TEST(StreamCall, AStreamThatSentEveryFrameEndsOkWhateverCameAfter) {
  Serving serving;
  grpc::testing::ServerContextTestSpouse spouse(&serving.context);
  spouse.AddClientMetadata("authorization", "Bearer old");
  serving.state.set_tokens({"old"});
  StreamCall call(serving.context, "StreamTiles", serving.state);
  RecordingWriter writer;
  for (const char* frame : {"frame 0", "frame 1"}) {
    ASSERT_TRUE(call.live());
    ASSERT_TRUE(call.write(writer, std::string(frame)));
  }
  serving.state.set_phase(ServingState::Phase::Draining);
  serving.state.set_tokens({"new"});
  EXPECT_TRUE(call.cancellation().requested()) << "the engines' work would stop";
  EXPECT_TRUE(call.status().ok()) << call.status().error_message();
  EXPECT_FALSE(call.live()) << "a handler with another frame to make is stopped";
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::UNAVAILABLE);
}

// Work that stopped because the call was no longer wanted (the engines' Error(Cancelled)) ends the stream
// with why, not OK.
TEST(ServeStream, WorkCancelledByADrainEndsUnavailable) {
  Serving serving;
  const grpc::Status status = serve_stream(serving.context, serving.state, "StreamEvolution", [&](StreamCall& call) {
    serving.state.set_phase(ServingState::Phase::Draining);
    call.cancellation().check("the volume's build");
  });
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
}

// A write the transport refuses (the client is gone) ends the call: nothing more is written.
TEST(StreamCall, AFailedWriteEndsTheCall) {
  Serving serving;
  StreamCall call(serving.context, "StreamTiles", serving.state);
  RecordingWriter writer;
  writer.accepts = false;
  EXPECT_FALSE(call.write(writer, std::string("frame 1")));
  EXPECT_FALSE(call.live());
  writer.accepts = true;
  EXPECT_FALSE(call.write(writer, std::string("frame 2")));
  EXPECT_TRUE(writer.written.empty());
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::CANCELLED);
}

// A stream outlives the tokens it was let in with: when they are read again (SIGHUP), a stream whose token is
// still among them goes on, and one whose token was dropped ends UNAUTHENTICATED.
TEST(StreamCall, AStreamWhoseTokenIsDroppedEndsUnauthenticated) {
  Serving serving;
  grpc::testing::ServerContextTestSpouse spouse(&serving.context);
  spouse.AddClientMetadata("authorization", "Bearer old");
  serving.state.set_tokens({"old"});
  serving.state.require_token(serving.context);
  StreamCall call(serving.context, "Run", serving.state);
  EXPECT_TRUE(call.live());
  serving.state.set_tokens({"new", "old"});
  EXPECT_TRUE(call.live()) << "its token is still accepted";
  struct Reader {
    bool Read(std::string* message) { return !(*message = "step").empty(); }
  } reader;
  std::string message;
  EXPECT_TRUE(call.read(reader, &message));
  serving.state.set_tokens({"new"});  // while the stream waits for its client's next message
  EXPECT_FALSE(call.read(reader, &message)) << "the message that comes next is not acted on";
  EXPECT_FALSE(call.live());
  EXPECT_EQ(call.status().error_code(), grpc::StatusCode::UNAUTHENTICATED) << call.status().error_message();
  serving.state.set_tokens({"new", "old"});
  EXPECT_FALSE(call.live()) << "a stream once ended stays ended";
}

// A stream's request is checked before it asks for a --max-streams slot (a bad request is refused for what it
// is, even when every slot is taken), and set up after it has one: setting up can bake a river, evaluate an
// ocean or reserve memory, work the slots bound. A refused setup gives the slot back.
TEST(ServeStream, TheRequestIsCheckedBeforeItsSlotAndSetUpAfter) {
  Limits limits;
  limits.max_streams = 1;
  Serving serving(limits);
  bool bad = true, set_up = false;
  auto check = [&] {
    if (bad) fail(Code::InvalidArgument, "request.field is bad");
    return 0;
  };
  auto prepare = [&](int&) {
    set_up = true;
    fail(Code::ResourceExhausted, "its bake would pass the memory budget");
  };
  auto run = [](StreamCall&, int) {};
  auto code = [&] { return serve_stream(serving.context, serving.state, "Run", check, prepare, run).error_code(); };
  {
    Slot open = serving.state.gate().acquire_stream();
    EXPECT_EQ(code(), grpc::StatusCode::INVALID_ARGUMENT);
    bad = false;
    const grpc::Status full = serve_stream(serving.context, serving.state, "Run", check, prepare, run);
    EXPECT_NE(full.error_message().find("--max-streams"), std::string::npos) << full.error_message();
    EXPECT_FALSE(set_up) << "set up for a stream that had no slot";
  }
  EXPECT_EQ(code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(set_up);
  EXPECT_EQ(serving.state.gate().open_streams(), 0u);
}

// A unary call holds one of the --max-calls slots for its length: while one runs under a limit of one, the
// next is refused naming the flag; once it has returned, the next runs.
TEST(Serve, AUnaryCallPastMaxCallsIsRefusedNamingTheFlag) {
  Limits limits;
  limits.max_calls = 1;
  Serving serving(limits);
  grpc::Status inner;
  const grpc::Status outer = serve(serving.context, serving.state, [&] {
    inner = serve(serving.context, serving.state, [] { return grpc::Status::OK; });
    return grpc::Status::OK;
  });
  EXPECT_TRUE(outer.ok()) << outer.error_message();
  EXPECT_EQ(inner.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(inner.error_message(), "calls: 1 running, the limit is --max-calls = 1");
  EXPECT_TRUE(serve(serving.context, serving.state, [] { return grpc::Status::OK; }).ok());
}

}  // namespace
}  // namespace squall::rpc
