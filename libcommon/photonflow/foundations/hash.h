// hash.h — SHA-256 (FIPS 180-4) for content hashes of inputs and for scene identity, and a fast
// 64-bit checksum that detects damage of the datasets in photonflow's HDF5 files.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

struct evp_md_ctx_st;  // OpenSSL's EVP_MD_CTX (openssl/types.h), kept out of this header

namespace pf {

// SHA-256 (FIPS 180-4) through OpenSSL's libcrypto (EVP interface), fed in pieces of any size:
// a file or a dataset is hashed as it streams, never held whole. Not copyable (it owns an
// EVP_MD_CTX); movable.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(Sha256&& other) noexcept;
  Sha256& operator=(Sha256&& other) noexcept;
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(const void* data, size_t len);
  std::string hex();  // finishes the hash; 64 lowercase hex digits; call once

 private:
  evp_md_ctx_st* ctx_ = nullptr;  // OpenSSL's EVP_MD_CTX
};

// Hash of a file's bytes. Throws InputError if the file cannot be read.
std::string sha256_file(const std::string& path);

// Checksum of n bytes for damage detection, not identity (no cryptographic strength): four lanes
// of 64-bit words, each lane a rotate-multiply chain (so the order of words counts), folded with
// the length and finished by the splitmix64 mixer. Several GB/s; every written dataset carries it
// (h5io.cpp, attribute checksum64) and every read verifies it.
uint64_t checksum64(const void* data, size_t n);

// SplitMix64's output function (Steele, Lea & Flood 2014), a bijective 64-bit mixer: checksum64's
// finish and the step of procedural.cpp's generator.
inline uint64_t splitmix64_mix(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace pf
