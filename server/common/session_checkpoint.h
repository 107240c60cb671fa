// The envelope of a checkpointed session: which kind of session, the version of its payload format, and
// the id it lived under, ahead of the capability's own payload. Layout (little-endian):
//   offset  size  field
//   0       8     magic "SQSESS\0\1"
//   8       4     kind length K, then K bytes of kind ("eWave session")
//   12+K    4     payload format version (the capability's)
//   16+K    4     id length I, then I bytes of id
//   20+K+I  8     payload length P + 8, then P bytes of payload and the checksum: 64-bit FNV-1a
//                 (common/fnv1a.h) of every byte before it, from the magic on
// The stored version carries kChecksummed (its top bit) with the checksum; without it (a squalld before
// checksums) the payload is P bytes with none after it. A squalld older than checksums reads the flagged
// version as a newer payload format than its own, so that it leaves the session to a newer replica.
// With kWithClient (the next bit) the P bytes begin with the client whose session it is (a u32 length C,
// then C bytes), which --max-sessions-per-client counts on the replica that resumes it; a squalld older
// than the flag leaves such a session to a newer replica in the same way.
// The checksum finds damage (a flipped bit, a torn write), not a forger: whoever can write the state
// directory is trusted.
#pragma once

#include <cstdint>
#include <string>

namespace squall {

inline constexpr uint32_t kChecksummed = 0x80000000u;
inline constexpr uint32_t kWithClient = 0x40000000u;

struct CheckpointHeader {
  std::string kind;
  uint32_t version = 0;
  std::string id;
  std::string client{};  // the client a --max-sessions-per-client slot is held for; "" for none
};

std::string encode_checkpoint(const CheckpointHeader& header, const std::string& payload);

// A session's payload and the format version it is written in: a store may write an older version when the
// session needs nothing newer, so that the daemons of a rolling update or a rollback read it.
struct VersionedPayload {
  uint32_t version = 0;
  std::string bytes;
};

// The payload of `data`; INVALID_ARGUMENT naming `field` when data is no checkpoint of `kind`, or one
// whose checksum does not match. header->version is the payload's version, without the flags.
std::string decode_checkpoint(const std::string& data, const std::string& kind, const std::string& field,
                              CheckpointHeader* header);

}  // namespace squall
