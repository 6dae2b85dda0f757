// Start-up check of a process's DDS Security files (hexa_deploy verify-security; the
// generated units run it as ExecStartPre, hexa_session --secure before any process starts).
//
// Cyclone DDS itself refuses to create a participant when a security file is missing,
// expired or signed by a foreign CA, so a bad file never runs open; but its messages do not
// always say which file. This check reads the <Security> section of the Cyclone
// configuration the process will use and names the file, the problem and the dates:
//   - every file exists and parses (CA, identity certificate, private key, governance,
//     permissions);
//   - the identity certificate is signed by the identity CA, is valid now, and matches the key;
//   - governance and permissions are S/MIME documents signed by the permissions CA;
//   - the permissions grant the identity's subject, are valid now, and cover the domain.
#pragma once

#include <ctime>
#include <optional>
#include <string>
#include <vector>

namespace hexa::deploy {

// The permissions document's validity dates: written by the generator (security_xml.cpp) and
// read back by the check, in UTC.
inline constexpr char kPermissionsTimeFormat[] = "%Y-%m-%dT%H:%M:%S";
// `t` as UTC text in strftime's `format` (kPermissionsTimeFormat, or "... UTC" for messages).
std::string FormatUtc(std::time_t t, const char* format);

struct SecurityFiles {
  bool has_security = false;  // the configuration has a <Security> section
  std::string identity_ca, identity_certificate, private_key;
  std::string permissions_ca, governance, permissions;
};

// Extracts the file paths from a Cyclone configuration text, expanding ${VAR} from the
// environment, with HEXA_IDENTITY taken from `identity` when given. Values must be "file:"
// URIs; an error names the element otherwise.
bool ReadSecurityFiles(const std::string& xml, const std::optional<std::string>& identity,
                       SecurityFiles& files, std::string& error);

struct SecurityCheck {
  bool ok = false;
  std::vector<std::string> errors;  // each names the file and what is wrong with it
  std::string summary;              // on success: subject and validity dates
};

SecurityCheck VerifySecurityFiles(const SecurityFiles& files, std::optional<int> domain,
                                  std::time_t now);

// Reads `dds_config_path` and checks its security files. A configuration without a
// <Security> section is an error here (the caller asked for a secured process).
SecurityCheck VerifyDdsConfigSecurity(const std::string& dds_config_path,
                                      const std::optional<std::string>& identity,
                                      std::optional<int> domain, std::time_t now);

}  // namespace hexa::deploy
