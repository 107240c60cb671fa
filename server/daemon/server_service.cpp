#include "daemon/server_service.h"

#include "rpc/status.h"
#include "runtime/device.h"

namespace squall::rpc {

namespace {

void fill_device(const DeviceInfo& info, bool selected, squall::v1::Device* out) {
  out->set_platform(info.platform);
  out->set_name(info.name);
  out->set_type(info.type);
  out->set_opencl_c_version(info.opencl_c_version);
  out->set_compute_units(info.compute_units);
  out->set_global_memory_bytes(info.global_memory_bytes);
  out->set_max_allocation_bytes(info.max_allocation_bytes);
  out->set_double_precision(info.double_precision);
  out->set_selected(selected);
}

}  // namespace

grpc::Status ServerService::GetInfo(grpc::ServerContext* context, const squall::v1::GetInfoRequest* request,
                                    squall::v1::GetInfoResponse* response) {
  return guarded([&] {
    daemon_.serving.require_token(*context);
    if (request->request_id().size() > 128)
      fail(Code::InvalidArgument,
           "request_id has " + std::to_string(request->request_id().size()) + " bytes: at most 128");
    response->set_version(SQUALL_VERSION);
    const Runtime& runtime = daemon_.runtime;
    for (const auto& found : find_devices())
      fill_device(found.info, found.device() == runtime.device()(), response->add_devices());
    bool ready = daemon_.serving.phase() != ServingState::Phase::Starting;
    if (ready) {  // builds and the FFT backend are written once, before ready turns true
      for (const auto& build : runtime.builds()) {
        auto* k = response->add_kernels();
        k->set_program(build.program);
        for (const auto& name : build.kernels) k->add_kernels(name);
        k->set_build_seconds(build.seconds);
      }
      response->set_fft_backend(daemon_.fft->name());
      response->set_device_queues(uint32_t(daemon_.runtime.queue_count()));
      response->set_fft_selection(daemon_.fft_selection);
    }
    const Limits& limits = daemon_.serving.gate().limits();
    auto* l = response->mutable_limits();
    l->set_max_grid_cells(limits.max_grid_cells);
    l->set_max_streams(limits.max_streams);
    l->set_max_sessions(limits.max_sessions);
    l->set_max_message_bytes(limits.max_message_bytes);
    l->set_stream_idle_timeout_seconds(limits.stream_idle_seconds);
    response->set_ready(ready);
    response->set_uptime_seconds(daemon_.serving.uptime_seconds());
    response->set_replica_id(daemon_.serving.replica_id());
    return grpc::Status::OK;
  });
}

}  // namespace squall::rpc
