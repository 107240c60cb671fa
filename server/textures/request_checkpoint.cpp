#include "textures/request_checkpoint.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include "common/byte_codec.h"
#include "common/error.h"
#include "common/fnv1a.h"

namespace squall::textures::rpc {

// A copy of the request (images and grids included), made once per stream that checkpoints or resumes.
uint64_t request_fingerprint(const squall::v1::AdvectTextureRequest& request) {
  squall::v1::AdvectTextureRequest shaping = request;
  shaping.clear_frames();
  shaping.clear_checkpoint_every();
  shaping.clear_resume_state();
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream out(&stream);
    out.SetSerializationDeterministic(true);  // the same fields, the same bytes
    shaping.SerializeToCodedStream(&out);
  }
  return fnv1a(kFnv1aOffsetBasis, bytes.data(), bytes.size());
}

std::string bind_checkpoint(uint64_t fingerprint, std::string_view state) {
  ByteWriter out;
  out.put(kCheckpointMagic);
  out.put(kCheckpointFormat);
  out.put(fingerprint);
  out.put(fnv1a(kFnv1aOffsetBasis, state.data(), state.size()));
  out.put_bytes(state);
  return out.take();
}

std::string_view bound_state(std::string_view resume_state, uint64_t fingerprint, const std::string& path) {
  ByteReader in(resume_state, path, "a texture checkpoint");
  if (in.get<uint32_t>("the magic number") != kCheckpointMagic || in.get<uint32_t>("the format") != kCheckpointFormat)
    in.reject("not a checkpoint of this server's AdvectTexture (format " + std::to_string(kCheckpointFormat) + ")");
  if (in.get<uint64_t>("the request's fingerprint") != fingerprint)
    fail(Code::InvalidArgument, path +
                                    " is the checkpoint of another request: every field but frames, "
                                    "checkpoint_every and resume_state must be as in the request that made it");
  const uint64_t checksum = in.get<uint64_t>("the state's checksum");
  if (in.left() == 0) in.reject("it holds no advection state");
  const std::string_view state = in.get_bytes(in.left(), "the advection's state");
  if (fnv1a(kFnv1aOffsetBasis, state.data(), state.size()) != checksum)
    fail(Code::InvalidArgument, path + " is damaged: its state does not match its checksum");
  return state;
}

}  // namespace squall::textures::rpc
