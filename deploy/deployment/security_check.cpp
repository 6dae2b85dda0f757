#include "security_check.hpp"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>

namespace hexa::deploy {

std::string FormatUtc(std::time_t t, const char* format) {
  char buf[64];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}

namespace {

template <typename T, void (*F)(T*)>
struct Deleter {
  void operator()(T* p) const { F(p); }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;
using KeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using StorePtr = std::unique_ptr<X509_STORE, Deleter<X509_STORE, X509_STORE_free>>;
using StoreCtxPtr = std::unique_ptr<X509_STORE_CTX, Deleter<X509_STORE_CTX, X509_STORE_CTX_free>>;
using Pkcs7Ptr = std::unique_ptr<PKCS7, Deleter<PKCS7, PKCS7_free>>;
void FreeBio(BIO* b) { BIO_free_all(b); }
using BioPtr = std::unique_ptr<BIO, Deleter<BIO, FreeBio>>;

std::string OpensslError() {
  std::string text;
  while (const unsigned long e = ERR_get_error()) {
    char buf[256];
    ERR_error_string_n(e, buf, sizeof buf);
    text += (text.empty() ? "" : "; ") + std::string(buf);
  }
  return text.empty() ? "no detail from openssl" : text;
}

std::string Expand(const std::string& value, const std::optional<std::string>& identity) {
  static const std::regex kVar(R"(\$\{([A-Za-z_][A-Za-z0-9_]*)\})");
  std::string out;
  auto begin = std::sregex_iterator(value.begin(), value.end(), kVar);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    out += value.substr(last, static_cast<std::size_t>(it->position()) - last);
    const std::string name = (*it)[1];
    if (name == "HEXA_IDENTITY" && identity) {
      out += *identity;
    } else if (const char* v = std::getenv(name.c_str())) {
      out += v;
    }
    last = static_cast<std::size_t>(it->position() + it->length());
  }
  return out + value.substr(last);
}

bool ReadFile(const std::string& path, std::string& text) {
  std::ifstream in(path);
  if (!in) return false;
  std::stringstream ss;
  ss << in.rdbuf();
  text = ss.str();
  return true;
}

std::string SubjectText(X509_NAME* name) {
  BioPtr bio(BIO_new(BIO_s_mem()));
  X509_NAME_print_ex(bio.get(), name, 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

std::string TimeText(const ASN1_TIME* t) {
  BioPtr bio(BIO_new(BIO_s_mem()));
  ASN1_TIME_print(bio.get(), t);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

// "CN=a,O=b" -> {CN:a, O:b}; the comparison Cyclone makes is order-insensitive.
std::map<std::string, std::string> SubjectFields(const std::string& subject) {
  std::map<std::string, std::string> fields;
  std::stringstream ss(subject);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) continue;
    auto trim = [](std::string s) {
      const auto b = s.find_first_not_of(' ');
      const auto e = s.find_last_not_of(' ');
      return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    };
    fields[trim(item.substr(0, eq))] = trim(item.substr(eq + 1));
  }
  return fields;
}

// "2026-11-23T01:02:03" (kPermissionsTimeFormat) -> time_t (UTC); -1 if malformed.
std::time_t ParseIsoTime(const std::string& text) {
  std::tm tm{};
  int n = 0;
  if (std::sscanf(text.c_str(), "%d-%d-%dT%d:%d:%d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                  &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &n) != 6)
    return -1;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return timegm(&tm);
}

// For messages: "2026-11-23 01:02:03 UTC".
std::string IsoTime(std::time_t t) { return FormatUtc(t, "%Y-%m-%d %H:%M:%S UTC"); }

X509Ptr LoadCert(const std::string& path, const char* what, std::vector<std::string>& errors) {
  BioPtr bio(BIO_new_file(path.c_str(), "r"));
  if (!bio) {
    errors.push_back(std::string(what) + " '" + path + "' cannot be read (missing file?)");
    ERR_clear_error();
    return nullptr;
  }
  X509Ptr cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
  if (!cert) errors.push_back(std::string(what) + " '" + path + "' is not a PEM certificate: " + OpensslError());
  return cert;
}

// Validity of a certificate at `now`; false + error when outside.
bool CheckDates(X509* cert, const std::string& path, const char* what, std::time_t now,
                std::vector<std::string>& errors) {
  std::time_t t = now;
  if (X509_cmp_time(X509_get0_notBefore(cert), &t) > 0) {
    errors.push_back(std::string(what) + " '" + path + "' is not valid yet: valid from " +
                     TimeText(X509_get0_notBefore(cert)) + ", now is " + IsoTime(now));
    return false;
  }
  if (X509_cmp_time(X509_get0_notAfter(cert), &t) < 0) {
    errors.push_back(std::string(what) + " '" + path + "' EXPIRED on " +
                     TimeText(X509_get0_notAfter(cert)) + " (now " + IsoTime(now) +
                     "): make a new one (deploy/make_security.sh)");
    return false;
  }
  return true;
}

// Verifies an S/MIME document against the CA; returns the signed content ("" on failure).
std::string VerifySigned(const std::string& path, const char* what, X509_STORE* store,
                         const std::string& ca_path, std::time_t now,
                         std::vector<std::string>& errors) {
  BioPtr in(BIO_new_file(path.c_str(), "r"));
  if (!in) {
    errors.push_back(std::string(what) + " '" + path + "' cannot be read (missing file?)");
    ERR_clear_error();
    return {};
  }
  BIO* content = nullptr;
  Pkcs7Ptr p7(SMIME_read_PKCS7(in.get(), &content));
  BioPtr content_owner(content);
  if (!p7) {
    errors.push_back(std::string(what) + " '" + path +
                     "' is not an S/MIME signed document (sign it with deploy/make_security.sh): " +
                     OpensslError());
    return {};
  }
  std::string signer = "unknown";
  if (STACK_OF(X509)* certs = PKCS7_get0_signers(p7.get(), nullptr, 0)) {
    if (sk_X509_num(certs) > 0) signer = SubjectText(X509_get_subject_name(sk_X509_value(certs, 0)));
    sk_X509_free(certs);
  }
  ERR_clear_error();
  X509_VERIFY_PARAM* param = X509_STORE_get0_param(store);
  X509_VERIFY_PARAM_set_time(param, now);
  BioPtr out(BIO_new(BIO_s_mem()));
  if (PKCS7_verify(p7.get(), nullptr, store, content, out.get(), PKCS7_TEXT) != 1) {
    errors.push_back(std::string(what) + " '" + path + "' is NOT signed by the permissions CA '" +
                     ca_path + "' (signed by '" + signer + "'): " + OpensslError());
    return {};
  }
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

std::string Element(const std::string& xml, const std::string& name) {
  const std::regex re("<" + name + ">\\s*([^<]*?)\\s*</" + name + ">");
  std::smatch m;
  return std::regex_search(xml, m, re) ? m[1].str() : std::string();
}

bool DomainListed(const std::string& xml, int domain) {
  static const std::regex kId(R"(<id>\s*([0-9]+)\s*</id>)");
  static const std::regex kRange(R"(<id_range>\s*<min>\s*([0-9]+)\s*</min>\s*(?:<max>\s*([0-9]+)\s*</max>)?\s*</id_range>)");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), kId); it != std::sregex_iterator(); ++it)
    if (std::stoi((*it)[1]) == domain) return true;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), kRange); it != std::sregex_iterator(); ++it) {
    const int lo = std::stoi((*it)[1]);
    const int hi = (*it)[2].matched ? std::stoi((*it)[2]) : 1 << 30;
    if (domain >= lo && domain <= hi) return true;
  }
  return false;
}

}  // namespace

bool ReadSecurityFiles(const std::string& xml, const std::optional<std::string>& identity,
                       SecurityFiles& files, std::string& error) {
  files = SecurityFiles{};
  files.has_security = xml.find("<Security>") != std::string::npos;
  if (!files.has_security) return true;
  struct Field {
    const char* element;
    std::string* out;
  };
  const Field fields[] = {{"IdentityCA", &files.identity_ca},
                          {"IdentityCertificate", &files.identity_certificate},
                          {"PrivateKey", &files.private_key},
                          {"PermissionsCA", &files.permissions_ca},
                          {"Governance", &files.governance},
                          {"Permissions", &files.permissions}};
  for (const auto& f : fields) {
    const std::string raw = Element(xml, f.element);
    if (raw.empty()) {
      error = std::string("<Security> has no <") + f.element + "> element";
      return false;
    }
    std::string value = Expand(raw, identity);
    if (value.rfind("file:", 0) != 0) {
      error = std::string("<") + f.element + "> '" + raw +
              "': only file: URIs are checked (this check cannot vouch for inline data)";
      return false;
    }
    value = value.substr(5);
    if (value.rfind("//", 0) == 0) value = value.substr(2);
    *f.out = value;
  }
  return true;
}

SecurityCheck VerifySecurityFiles(const SecurityFiles& f, std::optional<int> domain,
                                  std::time_t now) {
  SecurityCheck r;
  auto& errors = r.errors;
  X509Ptr id_ca = LoadCert(f.identity_ca, "identity CA", errors);
  X509Ptr perm_ca = f.permissions_ca == f.identity_ca ? nullptr
                                                      : LoadCert(f.permissions_ca, "permissions CA", errors);
  X509Ptr cert = LoadCert(f.identity_certificate, "identity certificate", errors);
  if (id_ca) CheckDates(id_ca.get(), f.identity_ca, "identity CA", now, errors);
  X509* pca = perm_ca ? perm_ca.get() : id_ca.get();

  std::string subject;
  if (cert) {
    subject = SubjectText(X509_get_subject_name(cert.get()));
    const bool dates_ok = CheckDates(cert.get(), f.identity_certificate, "identity certificate", now, errors);
    if (id_ca && dates_ok) {
      StorePtr store(X509_STORE_new());
      X509_STORE_add_cert(store.get(), id_ca.get());
      StoreCtxPtr ctx(X509_STORE_CTX_new());
      X509_STORE_CTX_init(ctx.get(), store.get(), cert.get(), nullptr);
      X509_STORE_CTX_set_time(ctx.get(), 0, now);
      if (X509_verify_cert(ctx.get()) != 1) {
        errors.push_back("identity certificate '" + f.identity_certificate + "' (" + subject +
                         ") is NOT issued by the identity CA '" + f.identity_ca + "' (" +
                         SubjectText(X509_get_subject_name(id_ca.get())) + "): " +
                         X509_verify_cert_error_string(X509_STORE_CTX_get_error(ctx.get())));
      }
    }
    BioPtr kb(BIO_new_file(f.private_key.c_str(), "r"));
    if (!kb) {
      errors.push_back("private key '" + f.private_key + "' cannot be read (missing file, or not "
                       "readable by this user?)");
      ERR_clear_error();
    } else {
      KeyPtr key(PEM_read_bio_PrivateKey(kb.get(), nullptr, nullptr, nullptr));
      if (!key) {
        errors.push_back("private key '" + f.private_key + "' is not a PEM private key: " + OpensslError());
      } else if (X509_check_private_key(cert.get(), key.get()) != 1) {
        ERR_clear_error();
        errors.push_back("private key '" + f.private_key + "' does not belong to the identity certificate '" +
                         f.identity_certificate + "'");
      }
    }
  }

  if (pca != nullptr) {
    StorePtr store(X509_STORE_new());
    X509_STORE_add_cert(store.get(), pca);
    const std::string& pca_path = perm_ca ? f.permissions_ca : f.identity_ca;
    const std::string gov = VerifySigned(f.governance, "governance", store.get(), pca_path, now, errors);
    if (!gov.empty() && domain && !DomainListed(gov, *domain))
      errors.push_back("governance '" + f.governance + "' has no rule for domain " + std::to_string(*domain));
    const std::string perm = VerifySigned(f.permissions, "permissions", store.get(), pca_path, now, errors);
    if (!perm.empty()) {
      const std::string granted = Element(perm, "subject_name");
      if (!subject.empty() && SubjectFields(granted) != SubjectFields(subject))
        errors.push_back("permissions '" + f.permissions + "' grant '" + granted +
                         "', not this identity '" + subject + "'");
      const std::time_t from = ParseIsoTime(Element(perm, "not_before"));
      const std::time_t to = ParseIsoTime(Element(perm, "not_after"));
      if (from < 0 || to < 0)
        errors.push_back("permissions '" + f.permissions + "' have no readable validity");
      else if (now < from)
        errors.push_back("permissions '" + f.permissions + "' are not valid before " + IsoTime(from));
      else if (now > to)
        errors.push_back("permissions '" + f.permissions + "' EXPIRED on " + IsoTime(to));
      if (domain && !DomainListed(perm, *domain))
        errors.push_back("permissions '" + f.permissions + "' grant nothing on domain " +
                         std::to_string(*domain));
    }
  }
  r.ok = errors.empty();
  if (r.ok && cert) {
    r.summary = "identity '" + subject + "' issued by '" +
                SubjectText(X509_get_subject_name(id_ca.get())) + "', valid until " +
                TimeText(X509_get0_notAfter(cert.get())) + "; governance and permissions signed by the permissions CA";
  }
  return r;
}

SecurityCheck VerifyDdsConfigSecurity(const std::string& dds_config_path,
                                      const std::optional<std::string>& identity,
                                      std::optional<int> domain, std::time_t now) {
  SecurityCheck r;
  std::string xml;
  if (!ReadFile(dds_config_path, xml)) {
    r.errors.push_back("DDS configuration '" + dds_config_path + "' cannot be read");
    return r;
  }
  SecurityFiles files;
  std::string error;
  if (!ReadSecurityFiles(xml, identity, files, error)) {
    r.errors.push_back("DDS configuration '" + dds_config_path + "': " + error);
    return r;
  }
  if (!files.has_security) {
    r.errors.push_back("DDS configuration '" + dds_config_path +
                       "' has no <Security> section: this process would run WITHOUT DDS Security "
                       "(refusing)");
    return r;
  }
  if (!identity && std::getenv("HEXA_IDENTITY") == nullptr &&
      xml.find("${HEXA_IDENTITY}") != std::string::npos) {
    r.errors.push_back("DDS configuration '" + dds_config_path +
                       "' names its identity through ${HEXA_IDENTITY}, which is not set "
                       "(give --identity or set HEXA_IDENTITY)");
    return r;
  }
  return VerifySecurityFiles(files, domain, now);
}

}  // namespace hexa::deploy
