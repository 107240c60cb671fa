#include "ewave/ewave_service.h"

#include "common/field_codec.h"
#include "ewave/ewave_request.h"
#include "ewave/shared_engine.h"
#include "rpc/metadata.h"
#include "rpc/streaming.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::ewave::rpc;

const std::string& session_id(const std::string& id) {
  if (id.empty()) fail(Code::InvalidArgument, "session_id is empty: pass the id CreateSession or Restore returned");
  return id;
}

void session_reply(const ewave::SessionView& session, v1::EWaveSessionResponse* response) {
  response->set_session_id(session.id);
  fill_config(session.config, response->mutable_config());
  response->set_step(session.steps);
  response->set_max_dt(ewave::max_dt(session.config));
}

// A session made for a caller that has gone meanwhile (its deadline passed while the session was built)
// is held by nobody: it is closed at once rather than kept until --session-ttl (that session only: not one
// made under its id since).
void refuse_if_gone(const grpc::ServerContext& context, ewave::EWaveEngine& engine, const ewave::SessionView& made) {
  if (!context.IsCancelled()) return;
  try {
    engine.close(made.id, made.serial);
  } catch (const Error& e) {
    if (e.code() != Code::NotFound) throw;  // closed already, or another session under its id now
  }
  fail(Code::Cancelled, "the session was made after the call ended (client gone or deadline passed): closed");
}

}  // namespace

void EWaveService::start(EngineContext& context) { engine_ = &ewave::shared_engine(context); }

void EWaveService::step(const v1::EWaveStepRequest& request, const Cancellation& cancel, v1::EWaveFrame* frame) {
  auto& ewave = *engine_;
  const std::string& id = session_id(request.session_id());
  // NOT_FOUND for an unknown, closed or evicted id. The step runs on this session, not on one made under
  // its id since.
  const ewave::SessionView session = ewave.view(id);
  const ewave::EWaveConfig& config = session.config;
  const auto outputs = squall::ewave::rpc::outputs(request.inputs());
  const v1::DType type = squall::field::dtype(request.inputs().dtype(), "inputs.dtype");
  // Refused before the step, so that a frame too large to send does not advance the session.
  const uint64_t reply_bytes = frame_bytes(config, outputs.size(), type);
  serving_.gate().check_message_bytes("EWaveFrame (ask for fewer outputs, or DTYPE_FLOAT16)", reply_bytes);
  const ewave::StepInputs in = inputs(request.inputs(), config, serving_.gate());
  ewave.check_runs_here(in);  // before its memory is reserved
  // Held while it runs: the frame's planes and reply, and the spectra and fields of the ocean it evaluates,
  // if any: its own, else the session's, where it brings no ambient height and an obstruction (without one,
  // h_A (1 - O) = 0 and the ocean is not evaluated: EWaveSession::ambient).
  std::string what = "Step's frame";
  std::optional<ocean::TileSpec> sea;
  const bool obstructed = !in.obstruction.empty() || !in.shapes.empty();
  if (obstructed && in.ambient_height.empty() && (in.ambient_ocean || config.ambient_ocean)) {
    what += in.ambient_ocean ? " and inputs.ambient_ocean" : " and config.ambient_ocean";
    sea = in.ambient_ocean ? in.ambient_ocean : config.ambient_ocean;
  }
  const auto ocean = ewave.ocean_bytes(config, sea);
  Slot memory = serving_.gate().acquire_memory(
      what, frame_host_bytes(config, in.outputs) + reply_bytes + ocean.working + ocean.new_spectra);
  Slot spectra = memory.split(ocean.new_spectra);
  serving_.gate().top_up(spectra, what + "'s spectra, built again",
                         [&] { return ewave.ocean_bytes(config, sea).new_spectra; });
  ewave::Frame result = ewave.step(id, in, guard(request, session.serial), {cancel, &spectra});
  frame->set_session_id(id);
  try {
    fill_frame(result, config, outputs, type, frame);
  } catch (const Error& e) {  // a value float16 cannot carry: known only now, after the step
    if (e.code() != Code::InvalidArgument) throw;
    const std::string again = request.retry_key().empty() ? "it has no retry_key to read its frame again"
                                                          : "its retry_key reads its frame again";
    fail(e.code(), "inputs.dtype: " + std::string(e.what()) + "; the step was made (the session is at step " +
                       std::to_string(result.step) + "), and " + again);
  }
}

grpc::Status EWaveService::CreateSession(grpc::ServerContext* context, const v1::EWaveCreateSessionRequest* request,
                                         v1::EWaveSessionResponse* response) {
  return serve(*context, serving_, [&] {
    const ewave::EWaveConfig c = config(request->config(), serving_.gate());
    engine_->check_runs_here(c);  // before its memory is reserved
    // An initial ocean is evaluated once, as the session is made: its new spectra and fields held meanwhile.
    const auto ocean = engine_->ocean_bytes(c, c.initial_ocean);
    Slot memory =
        serving_.gate().acquire_memory("CreateSession's config.initial_ocean", ocean.working + ocean.new_spectra);
    Slot spectra = memory.split(ocean.new_spectra);  // topped up by the engine once the session is reserved
    ewave::SessionView made;
    engine_->create(c, proposed_session(*context), {cancellation(*context), &spectra}, client_address(*context), &made);
    refuse_if_gone(*context, *engine_, made);
    session_reply(made, response);
    announce_session(*context, response->session_id());
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Step(grpc::ServerContext* context, const v1::EWaveStepRequest* request,
                                v1::EWaveFrame* response) {
  return serve(*context, serving_, [&] {
    step(*request, cancellation(*context), response);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Run(grpc::ServerContext* context,
                               grpc::ServerReaderWriter<v1::EWaveFrame, v1::EWaveStepRequest>* stream) {
  return serve_stream(*context, serving_, "Run", [&](StreamCall& call) {
    v1::EWaveStepRequest request;
    v1::EWaveFrame frame;
    for (uint64_t n = 0; call.live() && call.read(*stream, &request); ++n) {
      frame.Clear();
      try {
        step(request, call.cancellation(), &frame);
      } catch (const Error& e) {
        fail(e.code(), "Run message " + std::to_string(n) + ": " + e.what());
      }
      if (!call.write(*stream, frame)) return;
    }
  });
}

grpc::Status EWaveService::GetState(grpc::ServerContext* context, const v1::EWaveSessionRequest* request,
                                    v1::EWaveStateResponse* response) {
  return serve(*context, serving_, [&] {
    const std::string& id = session_id(request->session_id());
    // Its fields alone, known from the config before they are read: refused or reserved first.
    const ewave::SessionView session = engine_->view(id);  // read as this session's, not one made under its id since
    const uint64_t fields = ewave::state_field_bytes(session.config);
    serving_.gate().check_message_bytes("GetState reply (the session's state)", fields);
    const Slot memory = serving_.gate().acquire_memory("GetState's state", fields);
    std::string state = engine_->state(id, session.serial);
    serving_.gate().check_message_bytes("GetState reply (the session's state)", state.size());
    *response->mutable_state() = std::move(state);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Restore(grpc::ServerContext* context, const v1::EWaveRestoreRequest* request,
                                   v1::EWaveSessionResponse* response) {
  return serve(*context, serving_, [&] {
    ewave::SessionView made;
    engine_->create_from_state(request->state(), proposed_session(*context), client_address(*context), &made);
    refuse_if_gone(*context, *engine_, made);
    session_reply(made, response);
    announce_session(*context, response->session_id());
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::CloseSession(grpc::ServerContext* context, const v1::EWaveSessionRequest* request,
                                        v1::EWaveCloseResponse*) {
  return serve(*context, serving_, [&] {
    engine_->close(session_id(request->session_id()));
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
