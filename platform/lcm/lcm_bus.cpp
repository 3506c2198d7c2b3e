// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/lcm_bus.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <system_error>

#include <pthread.h>

#include <lcm/lcm-cpp.hpp>

namespace commerge::platform {

std::int64_t WallTimeUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::int64_t MonotonicUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

LcmBus::LcmBus(const LcmBusParams& params) : params_(params), fault_rng_(params.fault_seed) {}

LcmBus::~LcmBus() {
  stop_receiving_ = true;
  if (receiver_.joinable()) receiver_.join();  // it wakes at least every kReceiveWakeMs
}

Result<std::unique_ptr<LcmBus>> LcmBus::Create(const LcmBusParams& params) {
  if (params.max_queued_messages < 1 || params.max_queued_bytes < 65536 || params.lcm_queue_capacity < 0 ||
      !(params.delay_ms >= 0.0) ||
      !(params.jitter_ms >= 0.0) || !(params.duplicate_pct >= 0.0 && params.duplicate_pct <= 100.0)) {
    return InvalidArgument("LCM bus: max_queued_messages must be >= 1, max_queued_bytes >= 65536, "
                           "lcm_queue_capacity >= 0, delay_ms and jitter_ms >= 0, duplicate_pct in [0, 100]");
  }
  std::unique_ptr<LcmBus> bus(new LcmBus(params));
  if (params.authenticate) {
    auto auth = MessageAuthenticator::Create(params.auth);
    if (!auth.ok()) return auth.status();
    bus->auth_ = std::move(*auth);
  }
  bus->lcm_ = std::make_unique<lcm::LCM>(params.url);
  if (!bus->lcm_->good()) {
    return IoError("cannot open LCM at '" + (params.url.empty() ? std::string("the default URL (LCM_DEFAULT_URL)") : params.url) +
                   "': for udpm the interface needs a multicast route (e.g. `ip route add 224.0.0.0/4 dev lo`)");
  }
  return bus;
}

Status LcmBus::Subscribe(const std::string& regex) {
  lcm_subscription_t* sub = lcm_subscribe(lcm_->getUnderlyingLCM(), regex.c_str(), &LcmBus::OnMessageC, this);
  if (sub == nullptr) return InvalidArgument("cannot subscribe to LCM channels '" + regex + "'");
  if (params_.lcm_queue_capacity > 0 && lcm_subscription_set_queue_capacity(sub, params_.lcm_queue_capacity) != 0) {
    return InvalidArgument("cannot set the LCM queue capacity of '" + regex + "' to " +
                           std::to_string(params_.lcm_queue_capacity));
  }
  return Status::Ok();
}

void LcmBus::OnMessageC(const _lcm_recv_buf_t* rbuf, const char* channel, void* user) {
  static_cast<LcmBus*>(user)->OnMessage(static_cast<const std::uint8_t*>(rbuf->data), rbuf->data_size, channel,
                                        rbuf->recv_utime);
}

void LcmBus::OnMessage(const std::uint8_t* data, std::size_t n, const char* channel, std::int64_t recv_utime_us) {
  int sender = -1;
  const std::size_t wire_bytes = n;
  std::lock_guard<std::mutex> lock(mutex_);
  if (auth_) {
    std::size_t payload = 0;
    std::uint16_t from = 0;
    if (auth_->Verify(channel, data, n, &payload, &from) != AuthVerdict::kOk) return;  // counted in auth_stats()
    n = payload;
    sender = from;
  }
  if (queue_.size() >= params_.max_queued_messages || queued_bytes_ + n > params_.max_queued_bytes) {
    ++stats_.dropped_queue_full;
    return;
  }
  queue_.push_back(BusMessage{channel, std::vector<std::uint8_t>(data, data + n), sender, recv_utime_us});
  queued_bytes_ += n;
  ++stats_.received;
  stats_.received_bytes += wire_bytes;
  arrived_.notify_one();
}

namespace {
constexpr int kReceiveWakeMs = 50;  // how often the receive thread looks at its stop flag
}  // namespace

Status LcmBus::StartReceiveThread() {
  // Signals (SIGTERM from systemd, SIGINT) go to the caller's thread, whose handlers set the daemons' stop flags:
  // the receive thread starts with all of them blocked (it inherits the mask in force here).
  sigset_t all, previous;
  sigfillset(&all);
  if (pthread_sigmask(SIG_SETMASK, &all, &previous) != 0) return IoError("LCM bus: cannot block signals");
  try {
    receiver_ = std::thread([this] { ReceiveLoop(); });
  } catch (const std::system_error& e) {
    pthread_sigmask(SIG_SETMASK, &previous, nullptr);
    return IoError(std::string("LCM bus: cannot start the receive thread: ") + e.what());
  }
  pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  return Status::Ok();
}

void LcmBus::ReceiveLoop() {
  while (!stop_receiving_) {
    errno = 0;
    const int rc = lcm_->handleTimeout(kReceiveWakeMs);
    if (rc < 0 && errno != EINTR) {
      std::lock_guard<std::mutex> lock(mutex_);
      receive_error_ = IoError(std::string("LCM handle failed in the receive thread: ") + std::strerror(errno));
      arrived_.notify_one();
      return;
    }
  }
}

std::optional<AuthStats> LcmBus::auth_stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!auth_) return std::nullopt;
  return auth_->stats();
}

LcmBusStats LcmBus::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

Status LcmBus::Poll(int timeout_ms) {
  FlushDelayed();
  if (!delayed_.empty()) {
    const std::int64_t wait_ms = (delayed_.begin()->first - MonotonicUs()) / 1000;
    if (wait_ms < timeout_ms) timeout_ms = static_cast<int>(std::max<std::int64_t>(0, wait_ms));
  }
  if (params_.receive_thread) {
    if (!receiver_.joinable()) {
      if (Status st = StartReceiveThread(); !st.ok()) return st;
    }
    {
      std::unique_lock<std::mutex> lock(mutex_);
      arrived_.wait_for(lock, std::chrono::milliseconds(std::max(0, timeout_ms)),
                        [this] { return !queue_.empty() || !receive_error_.ok(); });
      if (!receive_error_.ok()) return receive_error_;
    }
    FlushDelayed();
    return Status::Ok();
  }
  errno = 0;
  int rc = lcm_->handleTimeout(timeout_ms);
  if (rc < 0 && errno == EINTR) rc = 0;  // a signal (SIGTERM from systemd, SIGINT) interrupted the wait: not an error
  if (rc < 0) return IoError(std::string("LCM handle failed: ") + std::strerror(errno));
  while (rc > 0 && lcm_->handleTimeout(0) > 0) {
  }
  FlushDelayed();
  return Status::Ok();
}

bool LcmBus::Take(BusMessage* out) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (queue_.empty()) return false;
  *out = std::move(queue_.front());
  queue_.pop_front();
  queued_bytes_ -= out->bytes.size();
  return true;
}

Status LcmBus::PublishNow(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
  const bool sent = lcm_->publish(channel, bytes.data(), static_cast<unsigned int>(bytes.size())) == 0;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!sent) {
    ++stats_.publish_errors;
    return IoError("LCM publish on " + channel + " failed");
  }
  ++stats_.published;
  stats_.published_bytes += bytes.size();
  return Status::Ok();
}

void LcmBus::FlushDelayed() {
  const std::int64_t now = MonotonicUs();
  while (!delayed_.empty() && delayed_.begin()->first <= now) {
    (void)PublishNow(delayed_.begin()->second.channel, delayed_.begin()->second.bytes);
    delayed_.erase(delayed_.begin());
  }
}

Status LcmBus::Hold(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
  if (delayed_.size() >= params_.max_queued_messages) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.publish_errors;
    return ResourceExhausted("fault stage full (" + std::to_string(delayed_.size()) + " messages held)");
  }
  double hold_ms = params_.delay_ms;
  if (params_.jitter_ms > 0.0) hold_ms += std::uniform_real_distribution<double>(0.0, params_.jitter_ms)(fault_rng_);
  delayed_.emplace(MonotonicUs() + static_cast<std::int64_t>(hold_ms * 1000.0), BusMessage{channel, bytes});
  return Status::Ok();
}

Status LcmBus::Publish(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
  const std::vector<std::uint8_t>* out = &bytes;
  if (auth_) {  // set once in Create; Sign shares the authenticator's state with the receive thread's Verify
    sign_buffer_.assign(bytes.begin(), bytes.end());
    std::lock_guard<std::mutex> lock(mutex_);
    auth_->Sign(channel, &sign_buffer_);
    out = &sign_buffer_;
  }
  if (!fault_stage()) return PublishNow(channel, *out);
  if (Status st = Hold(channel, *out); !st.ok()) return st;
  if (params_.duplicate_pct > 0.0 &&
      std::uniform_real_distribution<double>(0.0, 100.0)(fault_rng_) < params_.duplicate_pct) {
    return Hold(channel, *out);
  }
  return Status::Ok();
}

Status LcmBus::PublishRaw(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
  return PublishNow(channel, bytes);
}

Result<std::unique_ptr<LcmBus>> OpenLcmBus(const LcmBusParams& params, std::initializer_list<const char*> channels) {
  auto bus = LcmBus::Create(params);
  if (!bus.ok()) return bus.status();
  for (const char* channel : channels) {
    if (Status st = (*bus)->Subscribe(channel); !st.ok()) return st;
  }
  return bus;
}

}  // namespace commerge::platform
