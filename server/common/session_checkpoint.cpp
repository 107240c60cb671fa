#include "common/session_checkpoint.h"

#include <cstdio>
#include <mutex>
#include <random>

#include "common/byte_codec.h"
#include "common/fnv1a.h"
#include "common/session_store.h"

namespace squall {
namespace {

constexpr char kMagic[8] = {'S', 'Q', 'S', 'E', 'S', 'S', 0, 1};

// The kind, the id and the client: a u32 length, then the bytes.
void put_string(ByteWriter& out, const std::string& s) {
  out.put(uint32_t(s.size()));
  out.put_bytes(s);
}

std::string get_string(ByteReader& in, const std::string& member) {
  return std::string(in.get_bytes(in.get<uint32_t>(member + " length"), member));
}

}  // namespace

std::string new_session_id(const std::string& prefix) {
  static std::mutex mutex;
  static std::random_device device;  // the kernel's CSPRNG (getrandom) on Linux
  std::lock_guard<std::mutex> lock(mutex);
  std::string id = prefix;
  for (int word = 0; word < 4; ++word) {  // 4 x 32 = 128 bits
    char hex[9];
    std::snprintf(hex, sizeof hex, "%08x", unsigned(device()));
    id += hex;
  }
  return id;
}

std::string encode_checkpoint(const CheckpointHeader& header, const std::string& payload) {
  std::string room;  // the whole checkpoint's, so that no append moves the payload
  const bool with_client = !header.client.empty();
  const size_t client_bytes = with_client ? sizeof(uint32_t) + header.client.size() : 0;
  room.reserve(sizeof kMagic + 3 * sizeof(uint32_t) + header.kind.size() + header.id.size() + client_bytes +
               payload.size() + 2 * sizeof(uint64_t));
  ByteWriter out(std::move(room));
  out.put_bytes(std::string_view(kMagic, sizeof kMagic));
  put_string(out, header.kind);
  out.put(header.version | kChecksummed | (with_client ? kWithClient : 0));
  put_string(out, header.id);
  out.put(uint64_t(client_bytes + payload.size() + sizeof(uint64_t)));
  if (with_client) put_string(out, header.client);
  out.put_bytes(payload);
  std::string bytes = out.take();
  const uint64_t checksum = fnv1a(kFnv1aOffsetBasis, bytes.data(), bytes.size());
  ByteWriter sealed(std::move(bytes));
  sealed.put(checksum);
  return sealed.take();
}

std::string decode_checkpoint(const std::string& data, const std::string& kind, const std::string& field,
                              CheckpointHeader* header) {
  ByteReader in(data, field, "a session checkpoint");
  if (in.get_bytes(sizeof kMagic, "the magic") != std::string_view(kMagic, sizeof kMagic)) in.reject("no magic number");
  header->kind = get_string(in, "the kind");
  if (header->kind != kind) in.reject("it holds a " + header->kind + ", not a " + kind);
  header->version = in.get<uint32_t>("the version");
  const bool checksummed = header->version & kChecksummed;
  const bool with_client = header->version & kWithClient;
  header->version &= ~(kChecksummed | kWithClient);
  header->id = get_string(in, "the id");
  if (header->id.empty()) in.reject("its id is empty");
  std::string_view payload = in.get_counted("the payload");
  in.finish("the payload");
  if (checksummed) {
    if (payload.size() < sizeof(uint64_t)) in.reject("its payload is shorter than its checksum");
    payload.remove_suffix(sizeof(uint64_t));
    const size_t sealed = data.size() - sizeof(uint64_t);
    ByteReader stored(std::string_view(data).substr(sealed), field, "a session checkpoint");
    if (stored.get<uint64_t>("the checksum") != fnv1a(kFnv1aOffsetBasis, data.data(), sealed))
      fail(Code::InvalidArgument, field + " is damaged: its checksum does not match its bytes");
  }
  header->client.clear();
  if (with_client) {
    ByteReader leading(payload, field, "a session checkpoint");
    header->client = get_string(leading, "the client");
    payload.remove_prefix(leading.offset());
  }
  return std::string(payload);
}

}  // namespace squall
