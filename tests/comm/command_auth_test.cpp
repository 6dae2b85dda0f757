// Command authentication (comm/command_auth.hpp): the MAC is HMAC-SHA256 truncated, a tag
// binds every field and the writer's participant, and the key file is checked.
#include "hexa/comm/command_auth.hpp"

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
