// Sign and verify one command sample with the session key (what a writer and a reader of a
// command topic pay per sample). Usage: build/bench/command_auth/bench_command_auth
#include <benchmark/benchmark.h>

#include "hexa/comm/command_auth.hpp"

namespace {

using namespace hexa::comm;

SessionKey Key() {
  SessionKey k;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(i * 7 + 1);
  return k;
}

template <typename T>
void BM_Sign(benchmark::State& state) {
  const CommandMac mac(Key());
  ParticipantPrefix writer{};
  writer.fill(0x42);
  T sample{};
  for (auto _ : state) {
    sample.header.tick += 1;
    SignCommand(mac, writer, sample);
    benchmark::DoNotOptimize(sample.auth_tag);
  }
}

template <typename T>
void BM_Verify(benchmark::State& state) {
  const CommandMac mac(Key());
  ParticipantPrefix writer{};
  writer.fill(0x42);
  T sample{};
  SignCommand(mac, writer, sample);
  bool ok = true;
  for (auto _ : state) {
    ok &= VerifyCommand(mac, writer, sample);
    benchmark::DoNotOptimize(ok);
  }
  if (!ok) state.SkipWithError("a tag did not verify");
}

BENCHMARK(BM_Sign<hexa_msg_ValveCommand>);
BENCHMARK(BM_Verify<hexa_msg_ValveCommand>);
BENCHMARK(BM_Sign<hexa_msg_LegSetpoint>);
BENCHMARK(BM_Verify<hexa_msg_LegSetpoint>);

}  // namespace

BENCHMARK_MAIN();
