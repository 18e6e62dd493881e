// SPDX-License-Identifier: Apache-2.0
// The build summary (kiln/build_summary.hpp): what `kiln build` prints after a build, for people and as JSON.
#include "kiln/build_summary.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "kiln/manifest_json.hpp"

namespace kiln {
namespace {

using nlohmann::json;

std::string format_ms(double ms) {
  char text[32];
  if (ms >= 1000) std::snprintf(text, sizeof text, "%.2f s", ms / 1000);
  else std::snprintf(text, sizeof text, "%.1f ms", ms);
  return text;
}

const StageTiming* find_stage(const BuildReport& r, std::string_view stage) {
  for (const StageTiming& t : r.timings)
    if (t.stage == stage) return &t;
  return nullptr;
}

// The summary's times. Wall time first, the stages in order; the stages that stream together (each source compiles as
// soon as it is preprocessed) overlap, and the line says by how much, so that their times are not read as a sum. Then
// the workers' busy time (a job in flight, one job per process), summed over them: the CPU the compile took.
std::string time_lines(const BuildReport& r) {
  std::ostringstream out;
  out << "  time:";
  if (const StageTiming* total = find_stage(r, "total")) out << " " << format_ms(total->milliseconds) << " wall:";
  bool first = true;
  for (const StageTiming& t : r.timings) {
    if (t.stage == "total") continue;
    out << (first ? " " : ", ") << t.stage << " " << format_ms(t.milliseconds);
    first = false;
  }
  const StageTiming* preprocess = find_stage(r, "preprocess");
  const StageTiming* compile = find_stage(r, "compile");
  if (preprocess && compile) {
    const double overlap = std::min(preprocess->end_ms, compile->end_ms) - std::max(preprocess->start_ms, compile->start_ms);
    if (overlap > 0)
      out << " (preprocess and compile overlap by " << format_ms(overlap) << ": sources compile as they are preprocessed)";
  }
  out << "\n";
  if (!r.worker_timeline.empty()) {
    double preprocessing = 0, compiling = 0, idle = 0;
    for (const WorkerTimeline& w : r.worker_timeline) {
      preprocessing += w.preprocess_busy_ms;
      compiling += w.compile_busy_ms;
      idle += std::max(0.0, w.idle_ms);
    }
    out << "  workers: " << format_ms(preprocessing + compiling) << " busy, summed over " << r.worker_timeline.size()
        << (r.worker_timeline.size() == 1 ? " worker" : " workers") << ": preprocess " << format_ms(preprocessing)
        << ", compile " << format_ms(compiling) << "; idle " << format_ms(idle) << "\n";
  }
  return out.str();
}

}  // namespace

std::string build_summary_text(const BuildReport& r, const BuildOptions& options) {
  std::ostringstream out;
  const std::string shard =
      options.shard_count > 1 ? std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count) : "";
  if (!shard.empty() && (r.up_to_date || r.remote.pack_fetched)) {  // the pack of these inputs is there: no share to do
    out << "kiln: shard " << shard << ": " << (r.up_to_date ? "up to date: " : "fetched from the remote cache: ")
        << r.manifest.string() << "\n";
    return out.str();
  }
  if (!shard.empty()) {
    out << "kiln: shard " << shard << " of " << r.manifest.string() << ": compiled " << r.compiled << ", "
        << r.shard_skipped << " stage sources left to the other shards"
        << (r.shard_assembled ? "; every other shard had finished: wrote the pack from " +
                                    std::to_string(r.remote.shard_bundles) + " shard bundles\n"
                              : " (no pack written: the merge, or the shard that finishes last, writes it)\n");
    if (r.remote.configured)
      out << "  remote cache: hits " << r.remote.hits << ", uploads " << r.remote.uploads << " (" << r.remote.blobs_uploaded
          << " blobs), " << r.remote.bytes_up << " bytes up, errors " << r.remote.errors << "\n";
    out << time_lines(r);
    return out.str();
  }
  const Funnel& f = r.funnel;
  const bool built = !r.up_to_date && !r.remote.pack_fetched;  // else nothing was compiled or looked up
  out << "kiln: " << (r.up_to_date ? "up to date: " : r.remote.pack_fetched ? "fetched from the remote cache: " : "wrote ")
      << r.manifest.string() << "\n";
  out << "  variants: " << (f.declared_saturated ? "more than " : "") << f.declared << " declared -> " << f.valid
      << " valid -> " << f.kept << " after stripping";
  if (built)
    out << " -> " << f.stage_instances << " stage variants -> " << f.unique_preprocessed << " unique per stage -> "
        << f.unique_compiles << " compiles -> " << f.unique_modules << " modules -> " << f.unique_binaries
        << " unique binaries";
  out << "\n";
  if (built)
    out << "  compiled " << r.compiled << " (back ends " << r.back_ends << ", full legalizations "
        << r.full_legalizations << ", cached back ends " << r.back_end_hits
        << "), cache hits " << r.cache_hits << " (not preprocessed " << r.preprocess_memo_hits << ")"
        << (r.cache_rejected ? ", rejected cache entries " + std::to_string(r.cache_rejected) : std::string())
        << ", workers " << r.workers_started << "\n";
  if (!r.up_to_date && r.remote.configured && r.remote.pack_fetched)
    out << "  remote cache: the finished pack of these inputs, " << r.remote.bytes_down << " bytes down\n";
  else if (built && r.remote.configured)
    out << "  remote cache: hits " << r.remote.hits << ", misses " << r.remote.misses
        << (r.remote.incomplete ? " (" + std::to_string(r.remote.incomplete) + " entries found in part)" : std::string())
        << (r.remote.shard_bundles ? ", from " + std::to_string(r.remote.shard_bundles) + " shard bundles " +
                                         std::to_string(r.remote.shard_sources) + " stage sources"
                                   : std::string())
        << ", uploads " << r.remote.uploads
        << " (" << r.remote.blobs_uploaded << " blobs"
        << (r.remote.repaired ? ", " + std::to_string(r.remote.repaired) + " damaged entries repaired" : std::string()) << "), "
        << r.remote.bytes_down << " bytes down, " << r.remote.bytes_up
        << " bytes up, errors " << r.remote.errors << (r.remote.switched_off ? " (switched off)" : "") << "\n";
  if (built && !r.strip_report.empty()) {
    out << "  strip report:\n";
    for (const StripLine& line : r.strip_report)
      out << "    " << line.pass << ": " << line.what << ": " << line.count
          << (line.reason.empty() ? "" : " (" + line.reason + ")") << "\n";
  }
  out << time_lines(r);
  return out.str();
}

// `kiln build --summary-json FILE`: what the summary says, for CI dashboards; written whether the build
// succeeded or not (README.md lists the fields; they are only ever added).
std::string build_summary_json(const BuildReport& r, const DiagnosticSink& sink, int exit_code, const BuildOptions& options) {
  // The manifest's funnel fields (one field table: src/reader/manifest.cpp), and whether the count saturated.
  json funnel = static_cast<const ManifestFunnel&>(r.funnel);
  funnel["declared_saturated"] = r.funnel.declared_saturated;
  json timings = json::array();
  for (const StageTiming& t : r.timings)
    timings.push_back({{"stage", t.stage}, {"milliseconds", t.milliseconds}, {"start_ms", t.start_ms}, {"end_ms", t.end_ms}});
  json workers = json::array();
  for (const WorkerTimeline& w : r.worker_timeline)
    workers.push_back({{"spawned_ms", w.spawned_ms}, {"first_compile_ms", w.first_compile_ms >= 0 ? json(w.first_compile_ms) : json()},
                       {"idle_before_first_compile_ms", w.first_compile_ms >= 0 ? json(w.idle_before_first_compile_ms) : json()},
                       {"last_done_ms", w.last_done_ms}, {"preprocess_busy_ms", w.preprocess_busy_ms},
                       {"compile_busy_ms", w.compile_busy_ms}, {"idle_ms", w.idle_ms}, {"jobs", w.jobs}});
  json strip = json::array();
  for (const StripLine& line : r.strip_report)
    strip.push_back({{"pass", line.pass}, {"what", line.what}, {"count", line.count}, {"reason", line.reason}});
  json out{{"ok", r.ok},
           {"exit_code", exit_code},
           {"errors", sink.error_count()},
           {"warnings", sink.warning_count()},
           {"internal_errors", r.internal_errors},
           {"up_to_date", r.up_to_date},
           {"manifest", r.ok ? json(r.manifest.string()) : json()},
           {"funnel", funnel},
           {"compiled", r.compiled},
           {"back_ends", r.back_ends},
           {"back_end_cache_hits", r.back_end_hits},
           {"full_legalizations", r.full_legalizations},
           {"cache_hits", r.cache_hits},
           {"preprocess_memo_hits", r.preprocess_memo_hits},
           {"cache_rejected", r.cache_rejected},
           {"workers", r.workers_started},
           {"remote", {{"configured", r.remote.configured}, {"switched_off", r.remote.switched_off},
                       {"pack_fetched", r.remote.pack_fetched}, {"hits", r.remote.hits}, {"misses", r.remote.misses},
                       {"incomplete", r.remote.incomplete},
                       {"uploads", r.remote.uploads}, {"blobs_uploaded", r.remote.blobs_uploaded}, {"repaired", r.remote.repaired},
                       {"bytes_down", r.remote.bytes_down}, {"bytes_up", r.remote.bytes_up}, {"errors", r.remote.errors},
                       {"shard_bundles", r.remote.shard_bundles}, {"shard_sources", r.remote.shard_sources}}},
           {"timings", timings},
           {"worker_timeline", workers},
           {"strip_report", strip}};
  if (options.shard_count > 1)
    out["shard"] = {{"index", options.shard_index}, {"count", options.shard_count}, {"left_to_other_shards", r.shard_skipped},
                    {"assembled", r.shard_assembled}};
  return out.dump(2) + "\n";
}

}  // namespace kiln
