// Command authentication: only the session's own processes can command (docs/faults.md,
// "Foreign commands"). Every process of a session holds the session key (32 random bytes, a
// 0600 file made by hexa_session, 0640 by hexa_deploy, named by HEXA_SESSION_KEY or --session-key).
// Each sample of a command topic (ValveCommand, LegSetpoint, OperatorCommand) carries
// auth_tag = HMAC-SHA256(key, writer's participant GUID prefix || topic || every field),
// truncated to 16 bytes. A reader recomputes it with the GUID prefix of the writer that
// delivered the sample (its matched publication): a sample whose tag does not verify is
// refused. The GUID prefix binds a tag to the participant that wrote it: a foreign process
// that copies a real sample, tag and USER_DATA included, and writes it from its own
// participant does not pass.
//
// Per sample: two SHA-256 finalizations over the key's precomputed inner and outer states,
// no allocation (CommandMac). A writer's GUID prefix is looked up once per matched writer
// (an allocating call, when the writer first delivers a sample: PublicationPrefixCache).
#pragma once

#include <dds/dds.h>

#include <array>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "hexa.h"

namespace hexa::comm {

inline constexpr std::size_t kSessionKeyBytes = 32;
inline constexpr std::size_t kAuthTagBytes = 16;
// The environment variable that names the session key file (set by hexa_session for every
// child, and in every unit hexa_deploy generates).
inline constexpr const char* kSessionKeyEnvironment = "HEXA_SESSION_KEY";

struct SessionKey {
  std::array<std::uint8_t, kSessionKeyBytes> bytes{};
};

// A new random key (getrandom) written to `path` as 64 hex digits and a newline, mode 0600;
// an existing file is not overwritten. False with `error` naming the file and the reason.
bool WriteNewSessionKey(const std::string& path, std::string& error);
// Reads a key file: 64 hex digits (a trailing newline allowed), no permission for others and
// none to write for the group (0600, or 0640 for a service user's group, as the DDS Security
// keys of a deployment). Nullopt with `error` naming the file, what is wrong and
// what is expected.
std::optional<SessionKey> ReadSessionKey(const std::string& path, std::string& error);

// The GUID prefix (12 bytes) of a participant: every writer of one process shares it.
using ParticipantPrefix = std::array<std::uint8_t, 12>;
ParticipantPrefix PrefixOf(const dds_guid_t& guid);

// HMAC-SHA256 (RFC 2104) with the key's inner and outer hash states computed once, tag
// truncated to kAuthTagBytes (RFC 2104 section 5 allows truncation to half the output).
class CommandMac {
 public:
  explicit CommandMac(const SessionKey& key);
  void Tag(std::span<const std::uint8_t> message, std::uint8_t (&tag)[kAuthTagBytes]) const;

 private:
  static constexpr std::size_t kStateBytes = 112;  // sizeof(SHA256_CTX), checked in the .cpp
  alignas(8) std::array<unsigned char, kStateBytes> inner_{};
  alignas(8) std::array<unsigned char, kStateBytes> outer_{};
};

template <typename T>
concept CommandType = std::same_as<T, hexa_msg_ValveCommand> ||
                      std::same_as<T, hexa_msg_LegSetpoint> ||
                      std::same_as<T, hexa_msg_OperatorCommand>;

// Sets sample.auth_tag for a writer of participant `writer`.
void SignCommand(const CommandMac& mac, const ParticipantPrefix& writer, hexa_msg_ValveCommand& sample);
void SignCommand(const CommandMac& mac, const ParticipantPrefix& writer, hexa_msg_LegSetpoint& sample);
void SignCommand(const CommandMac& mac, const ParticipantPrefix& writer, hexa_msg_OperatorCommand& sample);
// True when sample.auth_tag is the tag of `writer` (constant-time comparison).
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& writer, const hexa_msg_ValveCommand& sample);
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& writer, const hexa_msg_LegSetpoint& sample);
bool VerifyCommand(const CommandMac& mac, const ParticipantPrefix& writer, const hexa_msg_OperatorCommand& sample);

// The process's session key, installed once before the first participant exists (services:
// node::InstallSessionKey). Writers and readers of the command topics take it at creation.
// Without one, writers send a zero tag and readers check nothing (CommandTrust::kUnchecked):
// a process started by hand without a key, outside a session, is told so in its log.
void InstallSessionKey(const SessionKey& key);
const CommandMac* InstalledCommandMac();  // nullptr: no key installed

// What a reader knows of a command sample's writer.
enum class CommandTrust : std::uint8_t {
  kAuthenticated,  // the tag verifies with the session key and the writer's GUID prefix
  kUnchecked,      // no session key in this process: nothing is checked
  kBadTag,         // the tag does not verify: not one of the session's processes
  kUnknownWriter,  // the writer is not (or no longer) a matched publication of the reader
};
const char* ToString(CommandTrust trust);
inline bool Trusted(CommandTrust t) { return t == CommandTrust::kAuthenticated || t == CommandTrust::kUnchecked; }

// Endpoint claims: what a writer says of itself in its USER_DATA ("leg=3 standby=0": the
// plant counts it as leg 3's primary before it has written anything) counts only when the
// session key vouches for it, by the rule of the command samples: the claim is followed by
// " auth=" and 32 hex digits, the HMAC tag of (the writer's participant GUID prefix, a code
// of its own, the claim). A process that copies a controller's USER_DATA, tag included, and
// creates a writer with it in its own participant does not pass.
// The USER_DATA a writer of participant `writer` offers for `claim`: the claim and its tag;
// the claim as it is without a key (nothing is checked then). Allocates: set-up only.
std::string SignEndpointClaim(const CommandMac* mac, const ParticipantPrefix& writer,
                              const std::string& claim);
// Checks a matched writer's USER_DATA: `claim` is the text before the tag. kAuthenticated
// when the tag verifies, kUnchecked without a key (`claim` is then all of `user_data`),
// kBadTag when the tag is missing or does not verify.
CommandTrust VerifyEndpointClaim(const CommandMac* mac, const ParticipantPrefix& writer,
                                 const std::string& user_data, std::string& claim);
// The same for a writer matched by `reader` (its USER_DATA and its GUID from discovery):
// kUnknownWriter when the reader does not know the publication (yet). Allocates.
CommandTrust MatchedWriterClaim(dds_entity_t reader, dds_instance_handle_t publication,
                                std::string& claim);
// The GUID prefix of an entity's participant (any entity of it); zeros on error.
ParticipantPrefix PrefixOfEntity(dds_entity_t entity);

// Publication handle -> GUID prefix of the writers a reader has received from. Fixed size:
// a lookup (allocating) only for a writer not seen before; when full, the oldest entry goes.
class PublicationPrefixCache {
 public:
  static constexpr std::size_t kEntries = 32;
  // False when `reader` no longer knows the publication.
  bool Find(dds_entity_t reader, dds_instance_handle_t publication, ParticipantPrefix& prefix);

 private:
  std::array<dds_instance_handle_t, kEntries> handles_{};
  std::array<ParticipantPrefix, kEntries> prefixes_{};
  std::size_t next_ = 0;
};

}  // namespace hexa::comm
