// How a node receives samples without writing its own static callback and mutex: the control
// cycle runs on Cyclone's receive thread, in the data callback of the readers it is triggered
// on (a sample is answered where it is received: docs/performance.md), under one control
// mutex that the node's main thread takes for what it shares with the cycle. Plus the
// allocation-free pieces a cycle uses to read: take-and-visit loops over a comm::Reader and a
// fixed-capacity queue of samples. Nothing here allocates once set up.
//
// Threading rule: the cycle function runs only with mutex() held (on the receive thread, or
// on the main thread through Run / RunHoldingLock); state it shares with the main thread is
// read there under the same mutex. sequence() is odd while a cycle runs (core
// ControlCycleWatch reads it without the mutex to tell a stuck cycle).
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>

#include <dds/dds.h>

#include "hexa/services/scheduling.hpp"

namespace hexa::services {

class ControlCycle {
 public:
  static constexpr std::size_t kMaxTriggers = 4;

  ControlCycle() = default;
  ControlCycle(const ControlCycle&) = delete;
  ControlCycle& operator=(const ControlCycle&) = delete;

  // The node's cycle: `Method` of `node`, called with mutex() held. Call before TriggerOn.
  template <auto Method, typename Node>
  void Bind(Node& node) {
    context_ = &node;
    cycle_ = [](void* n) { (static_cast<Node*>(n)->*Method)(); };
  }

  // Runs the cycle whenever `reader` (a comm::Reader or comm::LegReaders) has data. At most
  // kMaxTriggers readers; false when full.
  template <typename Reader>
  bool TriggerOn(Reader& reader) {
    if (triggers_ == kMaxTriggers) return false;
    detach_[triggers_++] = {&reader, [](void* r) { static_cast<Reader*>(r)->OnDataAvailable(nullptr, nullptr); }};
    reader.OnDataAvailable(&ControlCycle::OnData, this);
    return true;
  }

  // No callback runs the cycle any more once this returns (each reader's listener is reset).
  // The node calls it when its loop ends, before its readers are deleted.
  void StopTriggers() {
    for (std::size_t i = 0; i < triggers_; ++i) detach_[i].detach(detach_[i].reader);
    triggers_ = 0;
  }

  // One cycle from the calling thread (what arrived before the callbacks, or a cycle the main
  // thread must run): takes the mutex.
  void Run() {
    std::lock_guard<std::mutex> lock(mutex_);
    RunHoldingLock();
  }
  // The same, for a caller that holds mutex() already.
  void RunHoldingLock() {
    thread_id_.store(sched::CurrentThreadId(), std::memory_order_relaxed);
    sequence_.fetch_add(1, std::memory_order_acq_rel);  // odd: a cycle runs
    if (cycle_ != nullptr) cycle_(context_);
    sequence_.fetch_add(1, std::memory_order_acq_rel);
  }

  std::mutex& mutex() { return mutex_; }
  std::uint64_t sequence() const { return sequence_.load(std::memory_order_acquire); }
  // The kernel id of the thread that ran the newest cycle (0: none yet): while a cycle runs,
  // the thread it runs on (for the watch's scheduler statistics).
  int thread_id() const { return thread_id_.load(std::memory_order_relaxed); }
  std::size_t triggers() const { return triggers_; }

 private:
  static void OnData(void* self) { static_cast<ControlCycle*>(self)->Run(); }

  struct Detach {
    void* reader = nullptr;
    void (*detach)(void*) = nullptr;
  };
  std::mutex mutex_;
  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<int> thread_id_{0};
  void* context_ = nullptr;
  void (*cycle_)(void*) = nullptr;
  std::array<Detach, kMaxTriggers> detach_{};
  std::size_t triggers_ = 0;
};

// Takes everything `reader` holds, batch after batch, and calls visit(sample, k) for each
// sample with valid data (k: its index in the batch, for reader.info(k) / Authenticate(k)).
template <typename Reader, typename Visit>
void TakeValid(Reader& reader, Visit&& visit) {
  while (reader.Take() > 0) {
    for (std::size_t k = 0; k < reader.count(); ++k)
      if (reader.info(k).valid_data) visit(reader.sample(k), k);
  }
}

// The same with every sample, also those without data (a dispose, an unregistration):
// visit(info, k).
template <typename Reader, typename Visit>
void TakeEvery(Reader& reader, Visit&& visit) {
  while (reader.Take() > 0) {
    for (std::size_t k = 0; k < reader.count(); ++k) visit(reader.info(k), k);
  }
}

// Takes every valid sample and keeps the one with the highest header.tick in `newest` (not
// replaced by an older or equal tick). Returns whether a newer one came; `repeated` is set
// when the current newest tick came again (a lockstep re-ask).
template <typename Reader, typename T>
bool TakeNewest(Reader& reader, T& newest, bool& seen, bool& repeated) {
  bool fresh = false;
  repeated = false;
  TakeValid(reader, [&](const T& s, std::size_t) {
    if (seen && s.header.tick == newest.header.tick) repeated = true;
    if (seen && s.header.tick <= newest.header.tick) return;
    newest = s;
    seen = true;
    fresh = true;
  });
  return fresh;
}

// A fixed-capacity FIFO of samples (a ring): Push on a full queue drops the oldest and says
// so. No allocation; the storage lives in the object.
template <typename T, std::size_t N>
class SampleQueue {
 public:
  static_assert(N > 0);
  static constexpr std::size_t kCapacity = N;

  // Appends `sample`; true if the oldest had to be dropped to make room (it is in `dropped`).
  bool Push(const T& sample, T* dropped = nullptr) {
    bool overflow = false;
    if (size_ == N) {
      if (dropped != nullptr) *dropped = items_[head_];
      head_ = (head_ + 1) % N;
      --size_;
      overflow = true;
    }
    items_[(head_ + size_) % N] = sample;
    ++size_;
    return overflow;
  }
  // The oldest and the newest; the queue must not be empty.
  const T& front() const { return items_[head_]; }
  const T& back() const { return items_[(head_ + size_ - 1) % N]; }
  // Removes the oldest and returns it; its slot is reused only by a later Push.
  const T& Pop() {
    const std::size_t at = head_;
    head_ = (head_ + 1) % N;
    --size_;
    return items_[at];
  }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  bool full() const { return size_ == N; }

 private:
  std::array<T, N> items_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace hexa::services
