// SHA256_Init/Update/Final are deprecated in OpenSSL 3 in favour of EVP, whose contexts are
// allocated per use (EVP_MD_CTX_copy duplicates the provider context): the low-level calls
// keep the per-sample MAC allocation-free.
#define OPENSSL_SUPPRESS_DEPRECATED
#include "hexa/comm/command_auth.hpp"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/sha.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

namespace hexa::comm {
namespace {

static_assert(sizeof(SHA256_CTX) == 112, "CommandMac keeps SHA256_CTX states of 112 bytes");

constexpr std::size_t kBlockBytes = 64;  // SHA-256 block

// Topic codes in the MAC input: a tag of one topic never verifies as another's.
enum class TopicCode : std::uint8_t {
  kValveCommand = 1,
  kLegSetpoint = 2,
  kOperatorCommand = 3,
  kEndpointClaim = 4,  // a writer's USER_DATA (SignEndpointClaim)
};

// The canonical MAC input: little-endian fields into a fixed buffer (no padding bytes, no
// allocation). Every field of the sample except the tag.
class MacInput {
 public:
  MacInput(const ParticipantPrefix& writer, TopicCode topic) {
    Bytes(writer.data(), writer.size());
    U64(static_cast<std::uint64_t>(topic));
  }
  void U64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) Byte(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void I64(std::int64_t v) { U64(static_cast<std::uint64_t>(v)); }
  void F64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    U64(bits);
  }
  // A bounded string: its length, then its bytes up to the terminator or the bound.
  void Text(const char* s, std::size_t bound) {
    const std::size_t n = strnlen(s, bound);
    U64(n);
    Bytes(reinterpret_cast<const std::uint8_t*>(s), n);
  }
  void Header(const hexa_msg_SampleHeader& h) {
    U64(h.tick);
    F64(h.sim_time_s);
    I64(h.source_time_ns);
  }
  std::span<const std::uint8_t> bytes() const { return {buffer_.data(), size_}; }

 private:
  void Byte(std::uint8_t b) {
    if (size_ < buffer_.size()) buffer_[size_++] = b;
  }
  void Bytes(const std::uint8_t* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) Byte(p[i]);
  }
  std::array<std::uint8_t, 768> buffer_{};  // the largest input (OperatorCommand) is 628 bytes
  std::size_t size_ = 0;
};

MacInput InputOf(const ParticipantPrefix& w, const hexa_msg_ValveCommand& c) {
  MacInput m(w, TopicCode::kValveCommand);
  m.U64(c.leg_id);
  m.Header(c.header);
  m.F64(c.valve_v);
  m.U64(static_cast<std::uint64_t>(c.controller));
  m.U64(static_cast<std::uint64_t>(c.status));
  m.U64(c.standby ? 1 : 0);
  m.U64(c.setpoint_tick);
  m.F64(c.desired_length_m);
  m.F64(c.sliding_surface_m_s);
  m.F64(c.friction_scale);
  m.F64(c.compute_time_s);
  m.U64(c.feedback_valid ? 1 : 0);
  m.F64(c.feedback_force_n);
  m.F64(c.feedback_rate_n_s);
  m.U64(c.coupled ? 1 : 0);
  return m;
}

MacInput InputOf(const ParticipantPrefix& w, const hexa_msg_LegSetpoint& s) {
  MacInput m(w, TopicCode::kLegSetpoint);
  m.U64(s.leg_id);
  m.Header(s.header);
  m.F64(s.length_m);
  m.F64(s.velocity_m_s);
  m.F64(s.acceleration_m_s2);
  m.F64(s.correction_m);
  m.U64(s.hold ? 1 : 0);
  m.U64(s.feedforward_valid ? 1 : 0);
  m.F64(s.feedforward_force_n);
  m.F64(s.feedforward_force_rate_n_s);
  return m;
}

MacInput InputOf(const ParticipantPrefix& w, const hexa_msg_OperatorCommand& c) {
  MacInput m(w, TopicCode::kOperatorCommand);
  m.U64(c.sequence);
  m.U64(static_cast<std::uint64_t>(c.kind));
  m.Text(c.trajectory, sizeof c.trajectory);
  m.Text(c.csv_path, sizeof c.csv_path);
  m.I64(c.source_time_ns);
  m.U64(static_cast<std::uint64_t>(c.jog_frame));
  for (const double v : c.jog_velocity_m_s) m.F64(v);
  for (const double v : c.jog_angular_velocity_rad_s) m.F64(v);
  for (const double v : c.goal_position_m) m.F64(v);
  for (const double v : c.goal_orientation_wxyz) m.F64(v);
  for (const double v : c.pivot_m) m.F64(v);
  for (const double v : c.tool_position_m) m.F64(v);
  for (const double v : c.tool_orientation_wxyz) m.F64(v);
  for (const double v : c.work_position_m) m.F64(v);
  for (const double v : c.work_orientation_wxyz) m.F64(v);
  return m;
}

template <typename T>
void Sign(const CommandMac& mac, const ParticipantPrefix& w, T& sample) {
  const MacInput m = InputOf(w, sample);
  mac.Tag(m.bytes(), sample.auth_tag);
}

template <typename T>
bool Verify(const CommandMac& mac, const ParticipantPrefix& w, const T& sample) {
  const MacInput m = InputOf(w, sample);
  std::uint8_t tag[kAuthTagBytes];
  mac.Tag(m.bytes(), tag);
  return CRYPTO_memcmp(tag, sample.auth_tag, kAuthTagBytes) == 0;
}

constexpr const char* kClaimTag = " auth=";

// The tag of an endpoint claim as 32 lowercase hex digits.
std::string ClaimTagHex(const CommandMac& mac, const ParticipantPrefix& w, const std::string& claim) {
  MacInput m(w, TopicCode::kEndpointClaim);
  m.Text(claim.c_str(), claim.size());
  std::uint8_t tag[kAuthTagBytes];
  mac.Tag(m.bytes(), tag);
  static const char* kHex = "0123456789abcdef";
  std::string hex(2 * kAuthTagBytes, '0');
  for (std::size_t i = 0; i < kAuthTagBytes; ++i) {
    hex[2 * i] = kHex[tag[i] >> 4];
    hex[2 * i + 1] = kHex[tag[i] & 0xf];
  }
  return hex;
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::unique_ptr<const CommandMac>& InstalledSlot() {
  static std::unique_ptr<const CommandMac> mac;
  return mac;
}
std::atomic<const CommandMac*> g_installed{nullptr};

}  // namespace

bool WriteNewSessionKey(const std::string& path, std::string& error) {
  SessionKey key;
  std::size_t got = 0;
  while (got < key.bytes.size()) {
    const ssize_t n = getrandom(key.bytes.data() + got, key.bytes.size() - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = "session key '" + path + "': getrandom failed: " + std::strerror(errno);
      return false;
    }
    got += static_cast<std::size_t>(n);
  }
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    error = "session key '" + path + "': cannot create it: " + std::strerror(errno);
    return false;
  }
  static const char* kHex = "0123456789abcdef";
  char text[2 * kSessionKeyBytes + 1];
  for (std::size_t i = 0; i < kSessionKeyBytes; ++i) {
    text[2 * i] = kHex[key.bytes[i] >> 4];
    text[2 * i + 1] = kHex[key.bytes[i] & 0xf];
  }
  text[2 * kSessionKeyBytes] = '\n';
  const bool ok = write(fd, text, sizeof text) == static_cast<ssize_t>(sizeof text) && fsync(fd) == 0;
  const int saved = errno;
  close(fd);
  if (!ok) {
    error = "session key '" + path + "': cannot write it: " + std::strerror(saved);
    unlink(path.c_str());
    return false;
  }
  return true;
}

std::optional<SessionKey> ReadSessionKey(const std::string& path, std::string& error) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    error = "session key '" + path + "': " + std::strerror(errno);
    return std::nullopt;
  }
  if (!S_ISREG(st.st_mode)) {
    error = "session key '" + path + "': not a regular file";
    return std::nullopt;
  }
  if ((st.st_mode & 007) != 0 || (st.st_mode & 020) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    error = "session key '" + path + "': mode " + mode +
            " lets others use it or its group change it; it must be 0600 or 0640 (chmod 600)";
    return std::nullopt;
  }
  std::ifstream in(path);
  std::string text;
  if (!in || !std::getline(in, text)) {
    error = "session key '" + path + "': cannot read it";
    return std::nullopt;
  }
  std::string rest;
  if (text.size() != 2 * kSessionKeyBytes || (std::getline(in, rest) && !rest.empty())) {
    error = "session key '" + path + "': " + std::to_string(text.size()) +
            " characters on its first line (and nothing after); it must hold exactly " +
            std::to_string(2 * kSessionKeyBytes) + " hex digits";
    return std::nullopt;
  }
  SessionKey key;
  for (std::size_t i = 0; i < kSessionKeyBytes; ++i) {
    const int hi = HexDigit(text[2 * i]), lo = HexDigit(text[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      error = "session key '" + path + "': character " + std::to_string(2 * i + (hi < 0 ? 1 : 2)) +
              " is not a hex digit";
      return std::nullopt;
    }
    key.bytes[i] = static_cast<std::uint8_t>(hi << 4 | lo);
  }
  return key;
}

ParticipantPrefix PrefixOf(const dds_guid_t& guid) {
  ParticipantPrefix p{};
  std::memcpy(p.data(), guid.v, p.size());
  return p;
}

CommandMac::CommandMac(const SessionKey& key) {
  unsigned char pad[kBlockBytes];
  SHA256_CTX ctx;
  for (int which = 0; which < 2; ++which) {
    const unsigned char x = which == 0 ? 0x36 : 0x5c;  // ipad, opad
    std::memset(pad, x, sizeof pad);
    for (std::size_t i = 0; i < key.bytes.size(); ++i) pad[i] ^= key.bytes[i];
    SHA256_Init(&ctx);
    SHA256_Update(&ctx, pad, sizeof pad);
    std::memcpy(which == 0 ? inner_.data() : outer_.data(), &ctx, sizeof ctx);
  }
  OPENSSL_cleanse(pad, sizeof pad);
  OPENSSL_cleanse(&ctx, sizeof ctx);
}

void CommandMac::Tag(std::span<const std::uint8_t> message, std::uint8_t (&tag)[kAuthTagBytes]) const {
  SHA256_CTX ctx;
  unsigned char digest[SHA256_DIGEST_LENGTH];
  std::memcpy(&ctx, inner_.data(), sizeof ctx);
  SHA256_Update(&ctx, message.data(), message.size());
  SHA256_Final(digest, &ctx);
  std::memcpy(&ctx, outer_.data(), sizeof ctx);
  SHA256_Update(&ctx, digest, sizeof digest);
  SHA256_Final(digest, &ctx);
  std::memcpy(tag, digest, kAuthTagBytes);
}

void SignCommand(const CommandMac& mac, const ParticipantPrefix& w, hexa_msg_ValveCommand& s) { Sign(mac, w, s); }
void SignCommand(const CommandMac& mac, const ParticipantPrefix& w, hexa_msg_LegSetpoint& s) { Sign(mac, w, s); }
void SignCommand(const CommandMac& mac, const ParticipantPrefix& w, hexa_msg_OperatorCommand& s) { Sign(mac, w, s); }
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& w, const hexa_msg_ValveCommand& s) {
  return Verify(mac, w, s);
}
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& w, const hexa_msg_LegSetpoint& s) {
  return Verify(mac, w, s);
}
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& w, const hexa_msg_OperatorCommand& s) {
  return Verify(mac, w, s);
}

void InstallSessionKey(const SessionKey& key) {
  InstalledSlot() = std::make_unique<const CommandMac>(key);
  g_installed.store(InstalledSlot().get(), std::memory_order_release);
}

const CommandMac* InstalledCommandMac() { return g_installed.load(std::memory_order_acquire); }

const char* ToString(CommandTrust trust) {
  switch (trust) {
    case CommandTrust::kAuthenticated: return "authenticated";
    case CommandTrust::kUnchecked: return "unchecked (no session key)";
    case CommandTrust::kBadTag: return "tag does not verify with the session key";
    case CommandTrust::kUnknownWriter: return "writer unknown to the reader";
  }
  return "?";
}

std::string SignEndpointClaim(const CommandMac* mac, const ParticipantPrefix& writer,
                              const std::string& claim) {
  if (mac == nullptr) return claim;
  return claim + kClaimTag + ClaimTagHex(*mac, writer, claim);
}

CommandTrust VerifyEndpointClaim(const CommandMac* mac, const ParticipantPrefix& writer,
                                 const std::string& user_data, std::string& claim) {
  if (mac == nullptr) {
    claim = user_data;
    return CommandTrust::kUnchecked;
  }
  const std::size_t at = user_data.rfind(kClaimTag);
  if (at == std::string::npos) {
    claim = user_data;
    return CommandTrust::kBadTag;
  }
  claim = user_data.substr(0, at);
  const std::string given = user_data.substr(at + std::strlen(kClaimTag));
  const std::string expected = ClaimTagHex(*mac, writer, claim);
  if (given.size() != expected.size()) return CommandTrust::kBadTag;
  return CRYPTO_memcmp(given.data(), expected.data(), expected.size()) == 0
             ? CommandTrust::kAuthenticated
             : CommandTrust::kBadTag;
}

CommandTrust MatchedWriterClaim(dds_entity_t reader, dds_instance_handle_t publication,
                                std::string& claim) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return CommandTrust::kUnknownWriter;
  std::string user_data;
  void* value = nullptr;
  size_t size = 0;
  if (ep->qos != nullptr && dds_qget_userdata(ep->qos, &value, &size) && value != nullptr) {
    user_data.assign(static_cast<const char*>(value), size);
    dds_free(value);
  }
  const ParticipantPrefix writer = PrefixOf(ep->key);
  dds_builtintopic_free_endpoint(ep);
  return VerifyEndpointClaim(InstalledCommandMac(), writer, user_data, claim);
}

ParticipantPrefix PrefixOfEntity(dds_entity_t entity) {
  dds_guid_t guid{};
  if (dds_get_guid(entity, &guid) < 0) return {};
  return PrefixOf(guid);
}

bool PublicationPrefixCache::Find(dds_entity_t reader, dds_instance_handle_t publication,
                                  ParticipantPrefix& prefix) {
  for (std::size_t i = 0; i < kEntries; ++i) {
    if (handles_[i] == publication && publication != 0) {
      prefix = prefixes_[i];
      return true;
    }
  }
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (ep == nullptr) return false;
  prefix = PrefixOf(ep->key);
  dds_builtintopic_free_endpoint(ep);
  handles_[next_] = publication;
  prefixes_[next_] = prefix;
  next_ = (next_ + 1) % kEntries;
  return true;
}

}  // namespace hexa::comm
