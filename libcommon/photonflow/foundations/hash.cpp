// SHA-256 (FIPS 180-4) through OpenSSL's EVP digest interface, and checksum64.
#include "photonflow/foundations/hash.h"

#include <openssl/evp.h>

#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "photonflow/foundations/error.h"

namespace pf {

// libcrypto fails here only without memory or without a SHA-256 provider (a broken OpenSSL
// configuration): neither is bad input, so these are plain runtime errors.
Sha256::Sha256() : ctx_(EVP_MD_CTX_new()) {
  if (!ctx_) throw std::bad_alloc();
  if (EVP_DigestInit_ex(ctx_, EVP_sha256(), nullptr) != 1) {
    EVP_MD_CTX_free(ctx_);
    throw std::runtime_error("SHA-256: OpenSSL cannot start a SHA-256 digest");
  }
}

Sha256::~Sha256() { EVP_MD_CTX_free(ctx_); }

Sha256::Sha256(Sha256&& other) noexcept : ctx_(std::exchange(other.ctx_, nullptr)) {}

Sha256& Sha256::operator=(Sha256&& other) noexcept {
  std::swap(ctx_, other.ctx_);
  return *this;
}

void Sha256::update(const void* data, size_t len) {
  if (!ctx_) throw std::logic_error("Sha256::update on a moved-from hash");
  if (len > 0 && EVP_DigestUpdate(ctx_, data, len) != 1)
    throw std::runtime_error("SHA-256: OpenSSL's digest update failed");
}

std::string Sha256::hex() {
  if (!ctx_) throw std::logic_error("Sha256::hex on a moved-from hash");
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_DigestFinal_ex(ctx_, md, &n) != 1 || n != 32)
    throw std::runtime_error("SHA-256: OpenSSL's digest final failed");
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < n; ++i) {
    out += digits[md[i] >> 4];
    out += digits[md[i] & 0xf];
  }
  return out;
}

std::string sha256_file(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw input_error(path, "cannot open file for hashing", "check the path and permissions");
  Sha256 h;
  char buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) h.update(buf, n);
  bool bad = std::ferror(f);
  std::fclose(f);
  if (bad) throw input_error(path, "read error while hashing");
  return h.hex();
}

namespace {
constexpr uint64_t kP1 = 0x9E3779B185EBCA87ull, kP2 = 0xC2B2AE3D27D4EB4Full,
                   kP3 = 0x165667B19E3779F9ull;
inline uint64_t rotl64(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
inline uint64_t lane(uint64_t h, uint64_t w) { return rotl64(h ^ (w * kP2), 31) * kP1; }
inline uint64_t load64(const unsigned char* p) {
  uint64_t w;
  std::memcpy(&w, p, 8);
  return w;
}
}  // namespace

uint64_t checksum64(const void* data, size_t n) {
  const auto* b = static_cast<const unsigned char*>(data);
  uint64_t h[4] = {kP1, kP2, kP3, kP1 ^ kP2};
  size_t i = 0;
  for (; i + 32 <= n; i += 32)
    for (int l = 0; l < 4; ++l) h[l] = lane(h[l], load64(b + i + 8 * l));
  for (; i + 8 <= n; i += 8) h[0] = lane(h[0], load64(b + i));
  if (i < n) {  // the last bytes, zero-padded, tagged with their count
    unsigned char tail[8] = {};
    std::memcpy(tail, b + i, n - i);
    h[1] = lane(h[1], load64(tail) ^ (uint64_t(n - i) << 56));
  }
  uint64_t r = uint64_t(n) * kP3;
  for (int l = 0; l < 4; ++l) r = (r ^ lane(0, h[l])) * kP1 + kP3;
  return splitmix64_mix(r);
}

}  // namespace pf
