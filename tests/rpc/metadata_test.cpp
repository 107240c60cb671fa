// What the shared RPC layer reads from a call: the client a per-client limit counts.
#include <gtest/gtest.h>

#include "rpc/metadata.h"

namespace squall::rpc {
namespace {

TEST(ClientOfPeer, IsThePeersAddressWithoutItsPort) {
  EXPECT_EQ(client_of_peer("ipv4:127.0.0.1:5000"), "ipv4:127.0.0.1");
  EXPECT_EQ(client_of_peer("ipv4:127.0.0.1:41234"), client_of_peer("ipv4:127.0.0.1:41235"));
  EXPECT_EQ(client_of_peer("ipv6:[::1]:5000"), "ipv6:[::1]");
  EXPECT_EQ(client_of_peer("ipv6:[fe80::1%25eth0]:443"), "ipv6:[fe80::1%25eth0]");
}

TEST(ClientOfPeer, APeerWithNoPortIsKeptWhole) {
  EXPECT_EQ(client_of_peer("unix:/run/squalld.sock"), "unix:/run/squalld.sock");
  EXPECT_EQ(client_of_peer("ipv6:[::1]"), "ipv6:[::1]");
  EXPECT_EQ(client_of_peer(""), "");
}

}  // namespace
}  // namespace squall::rpc
