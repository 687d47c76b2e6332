#include "sar/workload.hpp"

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::sar {
namespace {

using workload::Config;
using workload::Kind;
using workload::ParamSpec;

constexpr const char* kHow =
    "the sar-net workload's samples come from a team of MPI processes: run `mpirun -n N dtflop sar --scenario FILE "
    "--exchange-sweep --store FILE` (docs/sar.md)";

class MpiBackend final : public workload::Backend {
 public:
  MpiBackend()
      : workload::Backend({"mpi", "the team's MPI exchange: one message to every other process (sar/team_mpi.cpp)",
                           false}) {}
  CostCounts counts(const Config& c, const MachineIdentity*) const override {
    const std::int64_t team = workload::get_int(c, "team"), bytes = workload::get_int(c, "bytes");
    CostCounts k;
    k.net_messages = team - 1;
    k.net_bytes = (team - 1) * bytes;
    return k;
  }
  // The protocol of calibrate/measure.hpp runs in one process; an exchange needs the team.
  // An exchange is messages and bytes: the latency variant prices both (the memory variant adds
  // only host terms an exchange does not count).
  Variant model_variant() const override { return Variant::latency; }
  std::string unavailable() const override { return std::string("backend mpi: ") + kHow; }
  std::unique_ptr<workload::Run> prepare(const Config&, std::int64_t) const override { throw InputError(kHow); }
};

class NetWorkload final : public workload::Workload {
 public:
  NetWorkload() {
    params_ = {
        {"team", Kind::integer, "processes of the team", 3, 2, 4096, {}, {}, "processes"},
        {"bytes", Kind::integer, "payload of one message (default: an observation, sar/world.hpp)", 48, 1, double(std::int64_t{1} << 30), {}, {}, "B"},
        {"exchanges", Kind::integer, "exchanges per repetition (a sample's steps)", 20, 1, 1e6, {}, {}, ""},
    };
    backends_.push_back(std::make_unique<MpiBackend>());
  }
  std::string_view name() const override { return "sar-net"; }
  std::string_view description() const override {
    return "the search-and-rescue team's network: an exchange of messages among its MPI processes";
  }
  std::string_view step_name() const override { return "exchange"; }
  const std::vector<ParamSpec>& params() const override { return params_; }
  const std::vector<std::unique_ptr<workload::Backend>>& backends() const override { return backends_; }
  std::string label(const Config& c) const override {
    return fmt::format("{} x {} B", workload::get_int(c, "team"), workload::get_int(c, "bytes"));
  }
  std::string describe(const workload::Backend&, const Config& c) const override {
    return fmt::format("each of {} processes sends {} bytes to every other", workload::get_int(c, "team"),
                       workload::get_int(c, "bytes"));
  }
  workload::PlanConfigs plan(const std::string&, const workload::Backend&, std::uint64_t) const override {
    throw InputError(kHow);
  }
  std::vector<std::pair<std::string, std::string>> plan_names() const override { return {}; }
  workload::ProtocolDefaults defaults(const workload::Backend&) const override { return {20, 5, 1}; }

 private:
  std::vector<ParamSpec> params_;
  std::vector<std::unique_ptr<workload::Backend>> backends_;
};

}  // namespace

const workload::Workload& net_workload() {
  static const NetWorkload w;
  return w;
}

}  // namespace dtflop::sar
