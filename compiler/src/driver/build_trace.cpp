// SPDX-License-Identifier: Apache-2.0
// The build's trace (driver/build_trace.hpp), in the Trace Event Format.
#include "driver/build_trace.hpp"

#include <algorithm>
#include <cstdint>
#include <map>

#include "kiln/output_file.hpp"

namespace kiln {
namespace {

using nlohmann::json;

constexpr int kDriverPid = 1;
constexpr int kWorkersPid = 2;
constexpr size_t kMaxTracksPerKind = 16;  // lookups; the stages always fit

json complete_event(const std::string& name, const std::string& category, int64_t start_us, int64_t end_us, int pid,
                    int tid, const json& args) {
  json event{{"name", name}, {"cat", category}, {"ph", "X"}, {"ts", start_us}, {"dur", end_us - start_us},
             {"pid", pid}, {"tid", tid}};
  if (!args.empty()) event["args"] = args;
  return event;
}

json name_event(const char* what, int pid, int tid, const std::string& name) {
  return {{"name", what}, {"ph", "M"}, {"pid", pid}, {"tid", tid}, {"args", {{"name", name}}}};
}

// Slices on as few tracks as nesting allows: each goes on the first track where it lies inside the innermost slice
// still open there, or after every one of them ended. Streamed stages and lookups in flight together overlap in
// part, which one track cannot show. Past `max_tracks` a slice is left out (counted in `left_out`): a thousand
// remote lookups in flight at once would be a thousand tracks.
template <typename Slice>
std::vector<std::vector<const Slice*>> lay_out(std::vector<const Slice*> slices, size_t max_tracks, size_t& left_out) {
  std::stable_sort(slices.begin(), slices.end(), [](const Slice* a, const Slice* b) {
    return a->start_us != b->start_us ? a->start_us < b->start_us : a->end_us > b->end_us;
  });
  std::vector<std::vector<int64_t>> open;  // per track: the ends of its open slices, innermost last
  std::vector<std::vector<const Slice*>> tracks;
  for (const Slice* slice : slices) {
    size_t t = 0;
    for (; t < tracks.size(); ++t) {
      std::vector<int64_t>& ends = open[t];
      while (!ends.empty() && ends.back() <= slice->start_us) ends.pop_back();
      if (ends.empty() || slice->end_us <= ends.back()) break;
    }
    if (t == max_tracks) {
      ++left_out;
      continue;
    }
    if (t == tracks.size()) {
      tracks.emplace_back();
      open.emplace_back();
    }
    tracks[t].push_back(slice);
    open[t].push_back(slice->end_us);
  }
  return tracks;
}

}  // namespace

void trace_stage(BuildTrace& trace, const std::string& stage, StageClock::time_point start, StageClock::time_point end) {
  trace.driver_slice("stages", stage, start, end);
}

int64_t BuildTrace::us(StageClock::time_point at) const {
  return std::max<int64_t>(0, std::chrono::duration_cast<std::chrono::microseconds>(at - started_).count());
}

void BuildTrace::driver_slice(std::string kind, std::string name, StageClock::time_point start,
                              StageClock::time_point end, json args) {
  const int64_t from = us(start);
  driver_.push_back({std::move(kind), {std::move(name), from, std::max(from, us(end)), std::move(args)}});
}

void BuildTrace::worker_job(const JobTiming& timing, std::string name, json args) {
  WorkerJob job;
  job.slot = timing.slot;
  job.job = {std::move(name), us(timing.sent), std::max(us(timing.sent), us(timing.answered)), std::move(args)};
  // The worker counts from the job's arrival, after it was sent (the first job of a worker also waits for the process to
  // start, 30-50 ms): its steps are placed from its arrival as the answer dates it (the answer, less the worker's time
  // on the job), never before the send, and clamped to the answer (the protocol checked that they are in order and do
  // not overlap).
  const int64_t arrived = std::max(job.job.start_us, job.job.end_us - static_cast<int64_t>(std::min<uint64_t>(
                                                                          timing.steps_elapsed_us, uint64_t{1} << 62)));
  for (const StepSpan& step : timing.steps) {
    const int64_t length = job.job.end_us - arrived;
    const int64_t from = arrived + static_cast<int64_t>(std::min<uint64_t>(step.start_us, static_cast<uint64_t>(length)));
    const int64_t to = std::min(job.job.end_us, from + static_cast<int64_t>(std::min<uint64_t>(step.duration_us, static_cast<uint64_t>(length))));
    job.steps.push_back({std::string(step_name(step.step)), from, to, json::object()});
  }
  jobs_.push_back(std::move(job));
}

std::string BuildTrace::to_json() const {
  json events = json::array();
  events.push_back(name_event("process_name", kDriverPid, 0, "kiln"));
  events.push_back(name_event("process_name", kWorkersPid, 0, "compiler workers"));
  // The driver's kinds in the order they came, the stages first.
  std::vector<std::string> kinds{"stages"};
  std::map<std::string, std::vector<const Slice*>> by_kind;
  for (const DriverSlice& d : driver_) {
    if (std::find(kinds.begin(), kinds.end(), d.kind) == kinds.end()) kinds.push_back(d.kind);
    by_kind[d.kind].push_back(&d.slice);
  }
  int tid = 0;
  size_t left_out = 0;
  for (const std::string& kind : kinds) {
    const auto tracks = lay_out(by_kind[kind], kind == "stages" ? SIZE_MAX : kMaxTracksPerKind, left_out);
    for (size_t t = 0; t < tracks.size(); ++t, ++tid) {
      events.push_back(name_event("thread_name", kDriverPid, tid, t ? kind + " " + std::to_string(t + 1) : kind));
      for (const Slice* slice : tracks[t])
        events.push_back(complete_event(slice->name, kind, slice->start_us, slice->end_us, kDriverPid, tid, slice->args));
    }
  }
  std::vector<unsigned> slots;
  for (const WorkerJob& job : jobs_) slots.push_back(job.slot);
  std::sort(slots.begin(), slots.end());
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  for (unsigned slot : slots)
    events.push_back(name_event("thread_name", kWorkersPid, static_cast<int>(slot), "worker " + std::to_string(slot)));
  for (const WorkerJob& job : jobs_) {
    const int slot = static_cast<int>(job.slot);
    events.push_back(complete_event(job.job.name, "job", job.job.start_us, job.job.end_us, kWorkersPid, slot, job.job.args));
    for (const Slice& step : job.steps)
      events.push_back(complete_event(step.name, "step", step.start_us, step.end_us, kWorkersPid, slot, step.args));
  }
  json trace{{"traceEvents", std::move(events)}, {"displayTimeUnit", "ms"}};
  if (left_out) trace["otherData"] = {{"lookups_left_out", left_out}};
  return trace.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
}

bool BuildTrace::write(DiagnosticSink& sink) const {
  Result<void> written = write_output_file(file_, to_json());
  if (!written)
    sink.report(DiagId::OutputUnwritable, SourceLocation{file_.string(), 0, 0}, "--trace: " + written.error().message);
  return bool(written);
}

}  // namespace kiln
