// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/message_auth.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>

#include <sodium.h>

namespace commerge::platform {

namespace {

constexpr std::size_t kSignedHeaderBytes = kAuthTrailerBytes - kAuthMacBytes;  // trailer bytes 0..23

void PutU16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
void PutU64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<std::uint8_t>(v);
}
std::uint64_t GetBe(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

void ComputeMac(const TeamKey& key, const char* channel, const std::uint8_t* payload, std::size_t payload_bytes,
                const std::uint8_t* header, std::uint8_t* mac_out) {
  crypto_auth_hmacsha256_state state;
  crypto_auth_hmacsha256_init(&state, key.bytes.data(), key.bytes.size());
  const std::uint8_t zero = 0;
  crypto_auth_hmacsha256_update(&state, reinterpret_cast<const unsigned char*>(channel), std::strlen(channel));
  crypto_auth_hmacsha256_update(&state, &zero, 1);
  crypto_auth_hmacsha256_update(&state, payload, payload_bytes);
  crypto_auth_hmacsha256_update(&state, header, kSignedHeaderBytes);
  std::uint8_t full[crypto_auth_hmacsha256_BYTES];
  crypto_auth_hmacsha256_final(&state, full);
  std::memcpy(mac_out, full, kAuthMacBytes);
  sodium_memzero(&state, sizeof(state));
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Status InitSodium() {
  if (sodium_init() < 0) return IoError("libsodium failed to initialise (no entropy source?)");
  return Status::Ok();
}

}  // namespace

const char* AuthVerdictName(AuthVerdict verdict) noexcept {
  switch (verdict) {
    case AuthVerdict::kOk: return "ok";
    case AuthVerdict::kOwnEcho: return "own echo";
    case AuthVerdict::kNoTrailer: return "no MAC trailer";
    case AuthVerdict::kUnknownKey: return "unknown key id";
    case AuthVerdict::kBadMac: return "bad MAC";
    case AuthVerdict::kUnknownSender: return "unknown sender";
    case AuthVerdict::kOldSession: return "old session";
    case AuthVerdict::kReplayed: return "replayed";
    case AuthVerdict::kTooOld: return "older than the replay window";
  }
  return "invalid";
}

Result<TeamKeyring> ParseTeamKeyring(const std::string& text, const std::string& source) {
  TeamKeyring ring;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = source + " line " + std::to_string(line_no);
    std::istringstream fields(line);
    std::string word;
    if (!(fields >> word) || word[0] == '#') continue;
    if (word != "key") return InvalidArgument(where + ": expected 'key <id> <64 hex digits>', found '" + word + "'");
    long id = -1;
    std::string hex, extra;
    if (!(fields >> id) || id < 0 || id > 255) return InvalidArgument(where + ": the key id must be 0..255");
    if (!(fields >> hex) || hex.size() != 2 * kAuthKeyBytes) {
      return InvalidArgument(where + ": the key must be " + std::to_string(2 * kAuthKeyBytes) + " hex digits, found " +
                             std::to_string(hex.size()));
    }
    if (fields >> extra && extra[0] != '#') return InvalidArgument(where + ": unexpected text after the key");
    TeamKey key;
    key.id = static_cast<std::uint8_t>(id);
    for (std::size_t i = 0; i < kAuthKeyBytes; ++i) {
      const int hi = HexDigit(hex[2 * i]), lo = HexDigit(hex[2 * i + 1]);
      if (hi < 0 || lo < 0) return InvalidArgument(where + ": the key has a character that is not a hex digit");
      key.bytes[i] = static_cast<std::uint8_t>(hi * 16 + lo);
    }
    for (const TeamKey& k : ring.keys) {
      if (k.id == key.id) return InvalidArgument(where + ": key id " + std::to_string(id) + " is listed twice");
    }
    if (ring.keys.size() == kAuthMaxKeys) {
      return InvalidArgument(where + ": more than " + std::to_string(kAuthMaxKeys) + " keys");
    }
    ring.keys.push_back(key);
  }
  if (ring.keys.empty()) {
    return InvalidArgument(source + ": no key (create one with `commerge keygen --out " + source + "`)");
  }
  return ring;
}

Result<TeamKeyring> LoadTeamKeyring(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    return IoError("cannot open the team key file " + path + ": " + std::strerror(errno) +
                   (errno == ELOOP ? " (a symbolic link: give the file itself)" : ""));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return InvalidArgument("the team key file " + path + " is not a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return InvalidArgument("the team key file " + path + " has mode " + mode +
                           ": it must be readable by its owner only (chmod 600 " + path + ")");
  }
  if (st.st_size > static_cast<off_t>(kAuthMaxKeyFileBytes)) {
    ::close(fd);
    return InvalidArgument("the team key file " + path + " has " + std::to_string(st.st_size) +
                           " bytes, more than a key file's " + std::to_string(kAuthMaxKeyFileBytes));
  }
  std::string text(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, &text[got], text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  ::close(fd);
  if (got != text.size()) return IoError("cannot read the team key file " + path);
  auto ring = ParseTeamKeyring(text, path);
  sodium_memzero(&text[0], text.size());
  return ring;
}

Result<TeamKey> GenerateTeamKey(std::uint8_t id) {
  if (Status st = InitSodium(); !st.ok()) return st;
  TeamKey key;
  key.id = id;
  randombytes_buf(key.bytes.data(), key.bytes.size());
  return key;
}

std::string FormatTeamKey(const TeamKey& key) {
  static const char kHex[] = "0123456789abcdef";
  std::string out = "key " + std::to_string(key.id) + " ";
  for (std::uint8_t b : key.bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  return out + "\n";
}

Status WriteNewKeyFile(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    return IoError("cannot create the key file " + path + ": " + std::strerror(errno) +
                   (errno == EEXIST ? " (refusing to overwrite a key)" : ""));
  }
  bool ok = ::fchmod(fd, 0600) == 0;
  std::size_t done = 0;
  while (ok && done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) ok = false;
    else done += static_cast<std::size_t>(n);
  }
  ok = (::fsync(fd) == 0) && ok;
  ok = (::close(fd) == 0) && ok;
  if (!ok) {
    ::unlink(path.c_str());
    return IoError("cannot write the key file " + path + ": " + std::strerror(errno));
  }
  return Status::Ok();
}

// ---- replay window ----

AuthVerdict ReplayWindow::Check(std::int64_t session, std::uint64_t sequence) const noexcept {
  if (session < session_) return AuthVerdict::kOldSession;
  if (session > session_ || sequence > top_) return AuthVerdict::kOk;
  const std::uint64_t back = top_ - sequence;
  if (back >= kReplayWindowMessages) return AuthVerdict::kTooOld;
  return (seen_[back / 64] >> (back % 64)) & 1u ? AuthVerdict::kReplayed : AuthVerdict::kOk;
}

void ReplayWindow::Accept(std::int64_t session, std::uint64_t sequence) noexcept {
  if (session > session_) {
    session_ = session;
    top_ = 0;
    seen_.fill(0);
  }
  if (sequence > top_) {
    // Shift the bitmap towards older entries by (sequence - top_).
    const std::uint64_t shift = sequence - top_;
    if (shift >= kReplayWindowMessages) {
      seen_.fill(0);
    } else {
      const std::size_t words = static_cast<std::size_t>(shift / 64), bits = static_cast<std::size_t>(shift % 64);
      for (std::size_t i = kWords; i-- > 0;) {
        std::uint64_t v = 0;
        if (i >= words) {
          v = seen_[i - words] << bits;
          if (bits != 0 && i >= words + 1) v |= seen_[i - words - 1] >> (64 - bits);
        }
        seen_[i] = v;
      }
    }
    top_ = sequence;
    seen_[0] |= 1u;
    return;
  }
  const std::uint64_t back = top_ - sequence;
  if (back < kReplayWindowMessages) seen_[back / 64] |= std::uint64_t{1} << (back % 64);
}

// ---- authenticator ----

std::uint64_t AuthStats::rejected() const noexcept {
  std::uint64_t n = 0;
  for (std::size_t v = 0; v < kAuthVerdictCount; ++v) {
    if (v != static_cast<std::size_t>(AuthVerdict::kOk) && v != static_cast<std::size_t>(AuthVerdict::kOwnEcho)) {
      n += verdicts[v];
    }
  }
  return n;
}

Result<std::unique_ptr<MessageAuthenticator>> MessageAuthenticator::Create(const MessageAuthParams& params) {
  if (params.keyring.keys.empty() || params.keyring.keys.size() > kAuthMaxKeys) {
    return InvalidArgument("message authentication: the key file must hold 1.." + std::to_string(kAuthMaxKeys) +
                           " keys");
  }
  for (std::size_t i = 0; i < params.keyring.keys.size(); ++i) {
    for (std::size_t j = i + 1; j < params.keyring.keys.size(); ++j) {
      if (params.keyring.keys[i].id == params.keyring.keys[j].id) {
        return InvalidArgument("message authentication: key id " + std::to_string(params.keyring.keys[i].id) +
                               " is listed twice");
      }
    }
  }
  if (params.session <= 0) return InvalidArgument("message authentication: the session must be > 0");
  if (params.max_robots < 1 || params.max_robots > kAuthMaxRobots) {
    return InvalidArgument("message authentication: max_robots must be 1.." + std::to_string(kAuthMaxRobots));
  }
  if (params.sender != kAuthServerSender && params.sender >= params.max_robots) {
    return InvalidArgument("message authentication: this robot's id " + std::to_string(params.sender) +
                           " is not below the team's robot count " + std::to_string(params.max_robots));
  }
  if (Status st = InitSodium(); !st.ok()) return st;
  return std::unique_ptr<MessageAuthenticator>(new MessageAuthenticator(params));
}

ReplayWindow* MessageAuthenticator::WindowOf(std::uint16_t sender) noexcept {
  if (sender == kAuthServerSender) return &windows_[kAuthMaxRobots];
  if (sender < params_.max_robots) return &windows_[sender];
  return nullptr;
}

void MessageAuthenticator::Sign(const std::string& channel, std::vector<std::uint8_t>* bytes) {
  const TeamKey& key = params_.keyring.keys.front();
  std::uint8_t trailer[kAuthTrailerBytes] = {};
  trailer[0] = 'C';
  trailer[1] = 'A';
  trailer[2] = 1;
  trailer[3] = key.id;
  PutU16(trailer + 4, params_.sender);
  PutU64(trailer + 8, static_cast<std::uint64_t>(params_.session));
  PutU64(trailer + 16, next_sequence_++);
  ComputeMac(key, channel.c_str(), bytes->data(), bytes->size(), trailer, trailer + kSignedHeaderBytes);
  bytes->insert(bytes->end(), trailer, trailer + kAuthTrailerBytes);
  ++stats_.signed_messages;
  stats_.trailer_bytes += kAuthTrailerBytes;
}

bool ReadAuthTrailer(const std::uint8_t* data, std::size_t size, AuthTrailerFields* out) noexcept {
  if (data == nullptr || size < kAuthTrailerBytes) return false;
  const std::uint8_t* t = data + (size - kAuthTrailerBytes);
  if (t[0] != 'C' || t[1] != 'A' || t[2] != 1 || t[6] != 0 || t[7] != 0) return false;
  out->key_id = t[3];
  out->sender = static_cast<std::uint16_t>(GetBe(t + 4, 2));
  out->session = static_cast<std::int64_t>(GetBe(t + 8, 8));
  out->sequence = GetBe(t + 16, 8);
  return true;
}

AuthVerdict MessageAuthenticator::Verify(const char* channel, const std::uint8_t* data, std::size_t size,
                                         std::size_t* payload_bytes, std::uint16_t* sender) {
  auto verdict = [&](AuthVerdict v) {
    ++stats_.verdicts[static_cast<std::size_t>(v)];
    if (v == AuthVerdict::kOk) ++stats_.accepted;
    return v;
  };
  AuthTrailerFields f;
  if (!ReadAuthTrailer(data, size, &f)) return verdict(AuthVerdict::kNoTrailer);
  const std::size_t payload = size - kAuthTrailerBytes;
  const std::uint8_t* t = data + payload;
  const TeamKey* key = nullptr;
  for (const TeamKey& k : params_.keyring.keys) {
    if (k.id == f.key_id) key = &k;
  }
  if (key == nullptr) return verdict(AuthVerdict::kUnknownKey);
  std::uint8_t mac[kAuthMacBytes];
  ComputeMac(*key, channel, data, payload, t, mac);
  if (sodium_memcmp(mac, t + kSignedHeaderBytes, kAuthMacBytes) != 0) return verdict(AuthVerdict::kBadMac);
  const std::uint16_t from = f.sender;
  const std::int64_t session = f.session;
  const std::uint64_t sequence = f.sequence;
  if (from == params_.sender && session == params_.session) return verdict(AuthVerdict::kOwnEcho);
  ReplayWindow* window = WindowOf(from);
  if (window == nullptr) return verdict(AuthVerdict::kUnknownSender);
  if (session <= 0 || sequence == 0) return verdict(AuthVerdict::kOldSession);
  const AuthVerdict v = window->Check(session, sequence);
  if (v != AuthVerdict::kOk) return verdict(v);
  window->Accept(session, sequence);
  *payload_bytes = payload;
  *sender = from;
  return verdict(AuthVerdict::kOk);
}

}  // namespace commerge::platform
