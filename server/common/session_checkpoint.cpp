#include "common/session_checkpoint.h"

#include <cstdio>
#include <cstring>
#include <mutex>
#include <random>

#include "common/error.h"
#include "common/session_store.h"

namespace squall {
namespace {

constexpr char kMagic[8] = {'S', 'Q', 'S', 'E', 'S', 'S', 0, 1};

template <typename U>
void put(std::string& out, U value) {
  char bytes[sizeof(U)];
  std::memcpy(bytes, &value, sizeof(U));
  out.append(bytes, sizeof(U));
}

void put_string(std::string& out, const std::string& s) {
  put<uint32_t>(out, uint32_t(s.size()));
  out += s;
}

// Reads fields front to back; any read past the end is INVALID_ARGUMENT naming the field.
class Reader {
 public:
  Reader(const std::string& data, const std::string& field) : data_(data), field_(field) {}

  template <typename U>
  U get() {
    U value;
    std::memcpy(&value, take(sizeof(U)), sizeof(U));
    return value;
  }
  std::string bytes(uint64_t n) { return std::string(take(n), n); }
  void finish() const {
    if (at_ != data_.size()) reject(std::to_string(data_.size() - at_) + " bytes follow the payload");
  }
  std::string string() { return bytes(get<uint32_t>()); }
  [[noreturn]] void reject(const std::string& why) const {
    fail(Code::InvalidArgument, field_ + " is not a session checkpoint: " + why);
  }

 private:
  const char* take(uint64_t n) {
    if (n > data_.size() - at_) reject("truncated at byte " + std::to_string(at_));
    const char* p = data_.data() + at_;
    at_ += n;
    return p;
  }
  const std::string& data_;
  const std::string& field_;
  size_t at_ = 0;
};

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
  std::string out(kMagic, sizeof kMagic);
  put_string(out, header.kind);
  put<uint32_t>(out, header.version);
  put_string(out, header.id);
  put<uint64_t>(out, payload.size());
  return out + payload;
}

std::string decode_checkpoint(const std::string& data, const std::string& kind, const std::string& field,
                              CheckpointHeader* header) {
  Reader in(data, field);
  if (in.bytes(sizeof kMagic) != std::string(kMagic, sizeof kMagic)) in.reject("no magic number");
  header->kind = in.string();
  if (header->kind != kind) in.reject("it holds a " + header->kind + ", not a " + kind);
  header->version = in.get<uint32_t>();
  header->id = in.string();
  if (header->id.empty()) in.reject("its id is empty");
  std::string payload = in.bytes(in.get<uint64_t>());
  in.finish();
  return payload;
}

}  // namespace squall
