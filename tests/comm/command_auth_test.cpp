// Command authentication (comm/command_auth.hpp): the MAC is HMAC-SHA256 truncated, a tag
// binds every field and the writer's participant, and the key file is checked.
#include "hexa/comm/command_auth.hpp"
#include "hexa/comm/trusted_writers.hpp"

#include <openssl/hmac.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "scratch_dir.hpp"

namespace {

using namespace hexa::comm;

SessionKey KeyOf(std::uint8_t seed) {
  SessionKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(seed * 31 + i);
  return k;
}

ParticipantPrefix PrefixOfByte(std::uint8_t b) {
  ParticipantPrefix p{};
  p.fill(b);
  return p;
}

hexa_msg_ValveCommand SomeCommand() {
  hexa_msg_ValveCommand c{};
  c.leg_id = 3;
  c.header.tick = 1234;
  c.header.sim_time_s = 1.234;
  c.header.source_time_ns = 1'700'000'000'000'000'000;
  c.valve_v = 5.25;
  c.setpoint_tick = 1230;
  c.desired_length_m = 0.61;
  return c;
}

TEST(CommandAuth, TheMacIsHmacSha256TruncatedTo16Bytes) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const SessionKey key = KeyOf(static_cast<std::uint8_t>(trial));
    std::vector<std::uint8_t> msg(static_cast<std::size_t>(trial * 3));
    for (auto& b : msg) b = static_cast<std::uint8_t>(rng());
    std::uint8_t tag[kAuthTagBytes];
    CommandMac(key).Tag(msg, tag);
    unsigned char full[32];
    unsigned int n = 0;
    ASSERT_NE(HMAC(EVP_sha256(), key.bytes.data(), static_cast<int>(key.bytes.size()), msg.data(),
                   msg.size(), full, &n), nullptr);
    ASSERT_EQ(n, 32u);
    EXPECT_EQ(std::memcmp(tag, full, kAuthTagBytes), 0) << "message of " << msg.size() << " bytes";
  }
}

TEST(CommandAuth, ATagVerifiesOnlyForItsKeyItsWriterAndItsFields) {
  const CommandMac mac(KeyOf(1));
  const ParticipantPrefix writer = PrefixOfByte(0xa1);
  hexa_msg_ValveCommand c = SomeCommand();
  SignCommand(mac, writer, c);
  EXPECT_TRUE(VerifyCommand(mac, writer, c));
  EXPECT_FALSE(VerifyCommand(CommandMac(KeyOf(2)), writer, c)) << "another session's key";
  EXPECT_FALSE(VerifyCommand(mac, PrefixOfByte(0xb2), c)) << "copied by another participant";
  auto tampered = [&](auto change) {
    hexa_msg_ValveCommand t = c;
    change(t);
    return VerifyCommand(mac, writer, t);
  };
  EXPECT_FALSE(tampered([](auto& t) { t.valve_v = 9.88; }));
  EXPECT_FALSE(tampered([](auto& t) { t.leg_id = 4; }));
  EXPECT_FALSE(tampered([](auto& t) { t.header.tick += 1; }));
  EXPECT_FALSE(tampered([](auto& t) { t.standby = true; }));
  EXPECT_FALSE(tampered([](auto& t) { t.header.source_time_ns += 1; }));
  EXPECT_FALSE(tampered([](auto& t) { t.auth_tag[15] ^= 1; }));
  hexa_msg_ValveCommand unsigned_command = SomeCommand();
  EXPECT_FALSE(VerifyCommand(mac, writer, unsigned_command)) << "a zero tag";
}

TEST(CommandAuth, SetpointsAndOperatorCommandsAreBoundToTheirFieldsToo) {
  const CommandMac mac(KeyOf(1));
  const ParticipantPrefix writer = PrefixOfByte(0x11);
  hexa_msg_LegSetpoint s{};
  s.leg_id = 2;
  s.header.tick = 500;
  s.length_m = 0.6;
  SignCommand(mac, writer, s);
  EXPECT_TRUE(VerifyCommand(mac, writer, s));
  s.hold = true;
  EXPECT_FALSE(VerifyCommand(mac, writer, s));
  hexa_msg_OperatorCommand o{};
  o.kind = hexa_msg_OPERATOR_START;
  std::strcpy(o.trajectory, "combined");
  SignCommand(mac, writer, o);
  EXPECT_TRUE(VerifyCommand(mac, writer, o));
  std::strcpy(o.trajectory, "x");
  EXPECT_FALSE(VerifyCommand(mac, writer, o));
  // The frames' fields, the sample's last: a pivot or a work frame changed after signing.
  o.kind = hexa_msg_OPERATOR_FRAMES;
  o.pivot_m[2] = 0.2;
  o.tool_orientation_wxyz[0] = 1.0;
  o.work_orientation_wxyz[0] = 1.0;
  SignCommand(mac, writer, o);
  EXPECT_TRUE(VerifyCommand(mac, writer, o));
  o.pivot_m[2] = 2.0;
  EXPECT_FALSE(VerifyCommand(mac, writer, o));
  o.pivot_m[2] = 0.2;
  o.work_orientation_wxyz[3] = 1e-12;
  EXPECT_FALSE(VerifyCommand(mac, writer, o));
  // A tag of one topic never verifies on another with the same bytes in its fields.
  hexa_msg_ValveCommand c{};
  std::memcpy(c.auth_tag, s.auth_tag, kAuthTagBytes);
  EXPECT_FALSE(VerifyCommand(mac, writer, c));
}

TEST(CommandAuth, AKeyFileIsWrittenPrivateReadBackAndCheckedWithClearErrors) {
  const std::string dir = hexa::testing::ScratchDir("command_auth");
  const std::string path = dir + "/session.key";
  std::string error;
  ASSERT_TRUE(WriteNewSessionKey(path, error)) << error;
  struct stat st {};
  ASSERT_EQ(stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const auto key = ReadSessionKey(path, error);
  ASSERT_TRUE(key) << error;
  EXPECT_FALSE(WriteNewSessionKey(path, error)) << "an existing key is not overwritten";
  EXPECT_NE(error.find("File exists"), std::string::npos) << error;
  std::string other = dir + "/other.key";
  ASSERT_TRUE(WriteNewSessionKey(other, error)) << error;
  EXPECT_NE(ReadSessionKey(other, error)->bytes, key->bytes) << "two keys from getrandom";

  chmod(path.c_str(), 0640);  // a service user's group may read it
  EXPECT_TRUE(ReadSessionKey(path, error)) << error;
  chmod(path.c_str(), 0644);
  EXPECT_FALSE(ReadSessionKey(path, error));
  EXPECT_NE(error.find("0644"), std::string::npos) << error;
  chmod(path.c_str(), 0660);
  EXPECT_FALSE(ReadSessionKey(path, error)) << "its group could change it";
  EXPECT_NE(error.find(path), std::string::npos) << error;
  const std::string short_key = dir + "/short.key";
  std::ofstream(short_key) << "abcd\n";
  chmod(short_key.c_str(), 0600);
  EXPECT_FALSE(ReadSessionKey(short_key, error));
  EXPECT_NE(error.find("64 hex digits"), std::string::npos) << error;
  const std::string bad = dir + "/bad.key";
  std::ofstream(bad) << std::string(63, 'a') << "g\n";
  chmod(bad.c_str(), 0600);
  EXPECT_FALSE(ReadSessionKey(bad, error));
  EXPECT_NE(error.find("character 64"), std::string::npos) << error;
  EXPECT_FALSE(ReadSessionKey(dir + "/none.key", error));
  EXPECT_NE(error.find("No such file"), std::string::npos) << error;
}

}  // namespace

namespace {

// A writer's USER_DATA claim ("leg=3 standby=0") counts only with the session key's tag for
// that writer's participant: the plant's count of each leg's writers and the intruder test
// (tests/integration/test_foreign_commands.cpp) rest on it.
TEST(CommandAuth, AnEndpointClaimVerifiesOnlyForItsKeyItsParticipantAndItsText) {
  const CommandMac mac(KeyOf(1));
  const ParticipantPrefix writer = PrefixOfByte(0x42);
  const std::string user_data = SignEndpointClaim(&mac, writer, "leg=3 standby=0");
  EXPECT_EQ(user_data.rfind("leg=3 standby=0 auth=", 0), 0u) << user_data;
  EXPECT_EQ(user_data.size(), std::string("leg=3 standby=0 auth=").size() + 2 * kAuthTagBytes);
  std::string claim;
  EXPECT_EQ(VerifyEndpointClaim(&mac, writer, user_data, claim), CommandTrust::kAuthenticated);
  EXPECT_EQ(claim, "leg=3 standby=0");
  const CommandMac other_key(KeyOf(2));
  EXPECT_EQ(VerifyEndpointClaim(&other_key, writer, user_data, claim), CommandTrust::kBadTag)
      << "another session's key";
  EXPECT_EQ(VerifyEndpointClaim(&mac, PrefixOfByte(0x43), user_data, claim), CommandTrust::kBadTag)
      << "the USER_DATA copied into another participant's writer";
  std::string forged = user_data;
  forged[4] = '4';  // "leg=4 ..." with leg 3's tag
  EXPECT_EQ(VerifyEndpointClaim(&mac, writer, forged, claim), CommandTrust::kBadTag);
  EXPECT_EQ(VerifyEndpointClaim(&mac, writer, "leg=3 standby=0", claim), CommandTrust::kBadTag)
      << "no tag at all";
  EXPECT_EQ(VerifyEndpointClaim(&mac, writer, user_data.substr(0, user_data.size() - 1), claim),
            CommandTrust::kBadTag) << "a truncated tag";
  // Without a session key nothing is checked: the claim is the whole text, as before keys.
  EXPECT_EQ(SignEndpointClaim(nullptr, writer, "leg=3 standby=0"), "leg=3 standby=0");
  EXPECT_EQ(VerifyEndpointClaim(nullptr, writer, "leg=3 standby=0", claim), CommandTrust::kUnchecked);
  EXPECT_EQ(claim, "leg=3 standby=0");
}

// A leg controller judges the supervisor present by its trusted setpoint writers only: a
// foreign writer that stays alive keeps no one present once the trusted one has left.
TEST(CommandAuth, OnlyWritersWithAuthenticatedSamplesCountAsPresent) {
  StatusCounters status;
  auto change = [&status](dds_instance_handle_t writer, int alive_change, int not_alive_change) {
    dds_liveliness_changed_status_t s{};
    s.alive_count_change = alive_change;
    s.not_alive_count_change = not_alive_change;
    s.last_publication_handle = writer;
    status.OnLivelinessChanged(s);
  };
  constexpr dds_instance_handle_t kSupervisor = 101, kIntruder = 202;
  change(kSupervisor, 1, 0);
  change(kIntruder, 1, 0);
  TrustedWriters trusted;
  EXPECT_FALSE(trusted.any());
  EXPECT_EQ(trusted.Present(status), 0u) << "nothing authenticated yet";
  trusted.Note(kIntruder, CommandTrust::kBadTag);
  trusted.Note(kIntruder, CommandTrust::kUnknownWriter);
  EXPECT_FALSE(trusted.any());
  trusted.Note(kSupervisor, CommandTrust::kAuthenticated);
  EXPECT_TRUE(trusted.Contains(kSupervisor));
  EXPECT_FALSE(trusted.Contains(kIntruder));
  EXPECT_EQ(trusted.Present(status), 1u);
  change(kSupervisor, -1, 1);  // its lease lapsed: still matched, still present
  EXPECT_EQ(trusted.Present(status), 1u);
  change(kSupervisor, 0, -1);  // its writer left
  EXPECT_EQ(trusted.Present(status), 0u) << "the intruder's live writer must not count";
  // Without a session key every writer's samples are unchecked, hence trusted.
  TrustedWriters unchecked;
  unchecked.Note(kIntruder, CommandTrust::kUnchecked);
  EXPECT_EQ(unchecked.Present(status), 1u);
}

}  // namespace
