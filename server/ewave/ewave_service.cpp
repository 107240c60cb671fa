#include "ewave/ewave_service.h"

#include "daemon/status.h"
#include "ewave/ewave_engine.h"
#include "ewave/ewave_request.h"

namespace squall::rpc {
namespace {

namespace v1 = squall::v1;
using namespace squall::ewave::rpc;

const std::string& session_id(const std::string& id) {
  if (id.empty()) fail(Code::InvalidArgument, "session_id is empty: pass the id CreateSession or Restore returned");
  return id;
}

void session_reply(ewave::EWaveEngine& engine, const std::string& id, v1::EWaveSessionResponse* response) {
  response->set_session_id(id);
  fill_config(engine.config(id), response->mutable_config());
}

}  // namespace

ewave::EWaveEngine& EWaveService::engine() {
  engines_.require_ready();
  engines_.ewave->evict_idle();
  return *engines_.ewave;
}

void EWaveService::step(const v1::EWaveStepRequest& request, v1::EWaveFrame* frame) {
  auto& ewave = engine();
  const std::string& id = session_id(request.session_id());
  const ewave::EWaveConfig config = ewave.config(id);  // NOT_FOUND for an unknown, closed or evicted id
  const auto outputs = squall::ewave::rpc::outputs(request.inputs());
  const v1::DType type = dtype(request.inputs().dtype(), "inputs.dtype");
  // Refused before the step, so that a frame too large to send does not advance the session.
  engines_.gate.check_message_bytes("EWaveFrame (ask for fewer outputs, or DTYPE_FLOAT16)",
                                    frame_bytes(config, outputs.size(), type));
  ewave::Frame result = ewave.step(id, inputs(request.inputs(), config));
  frame->set_session_id(id);
  fill_frame(result, config, outputs, type, frame);
}

grpc::Status EWaveService::CreateSession(grpc::ServerContext*, const v1::EWaveCreateSessionRequest* request,
                                         v1::EWaveSessionResponse* response) {
  return guarded([&] {
    auto& ewave = engine();
    session_reply(ewave, ewave.create(config(request->config(), engines_.gate)), response);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Step(grpc::ServerContext*, const v1::EWaveStepRequest* request, v1::EWaveFrame* response) {
  return guarded([&] {
    step(*request, response);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Run(grpc::ServerContext* context,
                               grpc::ServerReaderWriter<v1::EWaveFrame, v1::EWaveStepRequest>* stream) {
  const grpc::Status cancelled(grpc::StatusCode::CANCELLED, "Run cancelled (client gone, deadline or shutdown)");
  return guarded([&] {
    engines_.require_ready();
    Slot slot = engines_.gate.acquire_stream();  // released on every way out of this call
    v1::EWaveStepRequest request;
    v1::EWaveFrame frame;
    for (uint64_t n = 0; stream->Read(&request); ++n) {
      if (context->IsCancelled()) return cancelled;
      frame.Clear();
      try {
        step(request, &frame);
      } catch (const Error& e) {
        fail(e.code(), "Run message " + std::to_string(n) + ": " + e.what());
      }
      if (!stream->Write(frame)) return cancelled;
    }
    return context->IsCancelled() ? cancelled : grpc::Status::OK;
  });
}

grpc::Status EWaveService::GetState(grpc::ServerContext*, const v1::EWaveSessionRequest* request,
                                    v1::EWaveStateResponse* response) {
  return guarded([&] {
    auto& ewave = engine();
    std::string state = ewave.state(session_id(request->session_id()));
    engines_.gate.check_message_bytes("GetState reply (the session's state)", state.size() + 64);
    *response->mutable_state() = std::move(state);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::Restore(grpc::ServerContext*, const v1::EWaveRestoreRequest* request,
                                   v1::EWaveSessionResponse* response) {
  return guarded([&] {
    auto& ewave = engine();
    session_reply(ewave, ewave.create_from_state(request->state()), response);
    return grpc::Status::OK;
  });
}

grpc::Status EWaveService::CloseSession(grpc::ServerContext*, const v1::EWaveSessionRequest* request,
                                        v1::EWaveCloseResponse*) {
  return guarded([&] {
    engine().close(session_id(request->session_id()));
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
