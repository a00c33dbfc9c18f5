// SPDX-License-Identifier: MIT
// ced-mpi: `mpirun -np N ced-mpi detect big.las [ced detect's options]`, the
// tiles of a cloud shared between MPI ranks (Boost.MPI over OpenMPI).
//
// Rank 0 plans. LAS, LAZ and COPC files, and catalogues of them, are
// planned from their headers, and every rank fills the tile cache (in the
// work directory, on storage every rank sees: --work-dir) from its own block
// of the input, so that no rank reads the whole input; other inputs are
// planned and cached by rank 0 alone. Rank 0 then hands out tile ids from a queue, the
// largest tiles first; the other ranks detect them from the cache and keep
// each tile's part there. Rank 0 merges the parts and writes the outputs
// once. With one rank, rank 0 detects the tiles itself. A rank that fails
// makes the run fail, naming the rank and the tile; the finished tiles' parts
// stay in the work directory, and --resume redoes only the others.
#include <sched.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <boost/mpi.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "../cli/commands.hpp"
#include "../cli/common.hpp"
#include "../cli/detect.hpp"
#include "ced/ced.hpp"
#include "ced/tiled.hpp"

namespace mpi = boost::mpi;
using namespace ced_cli;

namespace {

// tag_beyond_reach: a tile's points reach beyond the neighbourhood's reach=
// (ced::tile_reach_error), which a rerun cannot mend: the cache goes.
// tag_short: the same when the reach was ced's own estimate, with how far
// the tile's points reach: rank 0 grows it for the next round.
enum tag : int { tag_ready = 1, tag_tile = 2, tag_done = 3, tag_failed = 4, tag_beyond_reach = 5, tag_short = 6 };

/// Threads a rank uses unless -j says: the cores it may run on (mpirun may
/// bind it to one), shared with the other ranks of its node when unbound.
unsigned threads_per_rank(int asked) {
  if (asked > 0) return static_cast<unsigned>(asked);
  const unsigned cores = ced::resolve_threads(0);  // its CPU affinity
  const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
  const unsigned ranks = local ? static_cast<unsigned>(std::max(1, std::atoi(local))) : 1u;
  const unsigned all = std::max(1u, std::thread::hardware_concurrency());
  return std::max(1u, cores < all ? cores : all / ranks);
}

/// What rank 0 makes before the tiles, and every rank learns: whether it
/// worked (an exit code and a message), the plan and the work directory;
/// or, when the ranks share the pass that fills the cache, the plan from
/// the headers (`begun`: ced::begin_cache_shares()).
struct prepared {
  int status = exit_ok;
  std::string message, plan_json, work_dir, begun;
  tiled_setup setup;  // rank 0's
};

/// Runs f(), turning what it throws into r's status and message.
template <class F>
void catching(prepared& r, F&& f) {
  try {
    f();
  } catch (const usage_error& e) {
    r.status = exit_usage;
    r.message = e.what();
  } catch (const ced::work_dir_error& e) {
    r.status = exit_usage;
    r.message = e.what();
  } catch (const std::exception& e) {
    r.status = exit_failure;
    r.message = e.what();
  }
}

/// Rank 0: checks the options, opens the outputs and plans: from the
/// headers, for the ranks to fill the cache between them (LAS, LAZ, COPC and
/// catalogues of them), else by passes, filling the cache itself.
void prepare(const detect_options& o, prepared& r, int ranks) {
  catching(r, [&] {
    if (!o.plan.empty()) throw usage_error("ced-mpi plans itself: no --plan");
    if (o.input.empty()) throw usage_error("give an input file");
    if (!wants_tiles(o)) throw usage_error("ced-mpi needs --tile-size or --memory-limit");
    r.setup = setup_tiled(o);
    r.work_dir = r.setup.run.work_dir;
    r.setup.run.planned = [&](const ced::tile_plan& p) { report_plan(p, o.quiet, /*grows_reach=*/true); };
    r.setup.run.reach_grown = reach_grown_report("ced-mpi", o.quiet);
    naming_file_fields(o, r.setup.plan, [&] {
      ced::tile_plan plan;
      r.begun = ced::begin_cache_shares(r.setup.request, r.setup.run, static_cast<unsigned>(ranks), plan);
      if (r.begun.empty()) r.plan_json = plan.to_json();
    });
  });
}

/// Every rank: its share of the pass that fills the cache; then rank 0
/// makes the plan from what every share learnt (r.plan_json, or r.status
/// and r.message when a rank failed).
void fill_shares(const detect_options& o, mpi::communicator& world, prepared& r, unsigned threads,
                 const ced::tiled_progress& progress) {
  ced::tiled_run_options run;
  run.work_dir = r.work_dir;
  run.threads = threads;
  run.progress = progress;  // rank 0's share
  std::string mine;
  try {
    mine = ced::fill_cache_share(r.begun, static_cast<unsigned>(world.rank()), run);
  } catch (const std::exception& e) {
    mine = "!rank " + std::to_string(world.rank()) + ": " + e.what();
  }
  std::vector<std::string> all;
  mpi::gather(world, mine, all, 0);
  if (world.rank() != 0) return;
  for (const std::string& a : all)
    if (!a.empty() && a[0] == '!') {
      r.status = exit_failure;
      r.message = a.substr(1);
      ced::remove_work_dir(r.work_dir);  // no plan: a rerun fills the cache again
      return;
    }
  catching(r, [&] {
    naming_file_fields(o, r.setup.plan,
                       [&] { r.plan_json = ced::finish_cache_shares(r.begun, all, r.setup.run).to_json(); });
  });
}

/// A rank other than 0: asks for a tile, detects it, reports, until told to
/// stop; then learns from rank 0 whether a round with a longer reach follows.
int work(const detect_options& o, mpi::communicator& world, const prepared& r, unsigned threads) {
  ced::tile_plan plan;
  std::string plan_json = r.plan_json;
  try {
    load_plugins(o.plugins);  // rank 0 loaded them in make_plan(); the plan's modalities may need them
  } catch (const std::exception& e) {
    world.send(0, tag_ready);
    long long id = -1;
    world.recv(0, tag_tile, id);
    world.send(0, tag_failed, "loading plugins: " + std::string(e.what()));
    return exit_failure;
  }
  for (;;) {
    // Every rank reads the plan from the same text: the same digest in every part.
    plan = ced::tile_plan::from_json(plan_json, r.work_dir + "/plan.json");
    for (;;) {
      world.send(0, tag_ready);
      long long id = -1;
      world.recv(0, tag_tile, id);
      if (id < 0) break;
      try {
        ced::detect_cached_tile(plan, r.work_dir, static_cast<std::uint64_t>(id), threads);
        world.send(0, tag_done, id);
      } catch (const ced::tile_reach_error& e) {
        if (plan.request.reach_estimated) {
          world.send(0, tag_short, e.needed);
          continue;
        }
        world.send(0, tag_beyond_reach, std::string(e.what()));
        return exit_failure;
      } catch (const std::exception& e) {
        world.send(0, tag_failed, "tile " + std::to_string(id) + ": " + e.what());
        return exit_failure;  // rank 0 aborts the run
      }
    }
    mpi::broadcast(world, plan_json, 0);  // the next round's plan, or none
    if (plan_json.empty()) return exit_ok;
  }
}

/// Rank 0: hands out the tiles of `queue` to the other ranks (or, alone,
/// detects them itself); report(done) after each tile. A tile that finds
/// ced's own reach short adds to `shortfall`. Aborts the run when a rank
/// fails.
void share_tiles(mpi::communicator& world, const ced::tile_plan& plan, const std::vector<ced::tile_entry>& queue,
                 const std::string& work_dir, unsigned threads, const std::function<void(std::size_t)>& report,
                 ced::reach_shortfall& shortfall) {
  std::size_t next = 0, done = 0;
  const std::size_t total = queue.size();
  if (world.size() == 1) {
    for (; next < total; ++next) {
      try {
        ced::detect_cached_tile(plan, work_dir, queue[next].id, threads);
      } catch (const ced::tile_reach_error& e) {
        if (!plan.request.reach_estimated) {
          ced::remove_work_dir(work_dir);  // a rerun with this reach fails again
          throw;
        }
        shortfall.add(e);
      }
      report(++done);
    }
    return;
  }
  for (int active = world.size() - 1; active > 0;) {
    const mpi::status s = world.probe();
    if (s.tag() == tag_ready) {
      world.recv(s.source(), tag_ready);
      const long long id = next < total ? static_cast<long long>(queue[next++].id) : -1;
      world.send(s.source(), tag_tile, id);
      if (id < 0) --active;
    } else if (s.tag() == tag_done) {
      long long id = 0;
      world.recv(s.source(), tag_done, id);
      report(++done);
    } else if (s.tag() == tag_short) {
      double needed = 0;
      world.recv(s.source(), tag_short, needed);
      shortfall.add(needed);
      report(++done);
    } else if (s.tag() == tag_beyond_reach) {
      std::string what;
      world.recv(s.source(), tag_beyond_reach, what);
      ced::remove_work_dir(work_dir);  // a rerun with this reach fails again
      std::cerr << "ced-mpi: error: " << what << "\n";
      world.abort(exit_failure);
    } else {
      std::string what;
      world.recv(s.source(), tag_failed, what);
      std::cerr << "ced-mpi: error: rank " << s.source() << " failed on " << what << "\n"
                << "ced-mpi: the finished tiles are kept in " << work_dir
                << ": run again with --resume to redo only the others\n";
      world.abort(exit_failure);
    }
  }
}

int run_mpi(const detect_options& o, mpi::communicator& world) {
  const bool root = world.rank() == 0;
  const auto t_start = clock_type::now();
  // Rank 0 checks the options, opens the outputs, plans and fills the cache;
  // every rank learns whether that worked.
  prepared r;
  if (root) prepare(o, r, world.size());
  const unsigned threads = threads_per_rank(o.threads);
  const auto failed = [&] {
    mpi::broadcast(world, r.status, 0);
    if (r.status != exit_ok && root) std::cerr << "ced-mpi: error: " << r.message << "\n";
    return r.status != exit_ok;
  };
  if (failed()) return r.status;
  mpi::broadcast(world, r.work_dir, 0);
  mpi::broadcast(world, r.begun, 0);
  // The progress of rank 0's share of the cache, then of the tiles, as ced detect's.
  progress_bar bar(progress_bar::mode_of(o.progress, root ? o.quiet : true));
  if (!r.begun.empty()) {  // no rank reads the whole input
    fill_shares(o, world, r, threads, root ? bar_progress(bar) : ced::tiled_progress());
    if (failed()) return r.status;
  }
  mpi::broadcast(world, r.plan_json, 0);
  if (!root) return work(o, world, r, threads);

  ced::tile_plan plan = ced::tile_plan::from_json(r.plan_json, r.work_dir + "/plan.json");
  const auto t_tiles = clock_type::now();
  std::size_t total = 0;
  for (;;) {
    // The queue, largest tiles first (their cost grows with density).
    std::vector<ced::tile_entry> queue = plan.tiles;
    std::stable_sort(queue.begin(), queue.end(),
                     [](const ced::tile_entry& a, const ced::tile_entry& b) { return a.points > b.points; });
    total = queue.size();
    ced::reach_shortfall shortfall;
    share_tiles(
        world, plan, queue, r.work_dir, threads, [&](std::size_t d) { bar.tiles(d, total, ms_since(t_tiles)); },
        shortfall);
    // A reach of ced's own that proved short: the next round detects the
    // short tiles with a longer one (the others keep their parts).
    std::string next_json;
    if (shortfall.any) {
      plan = ced::grow_tiled_reach(plan, shortfall, r.setup.run);
      next_json = plan.to_json();
    }
    if (world.size() > 1) mpi::broadcast(world, next_json, 0);
    if (next_json.empty()) break;
  }
  merged_writer writer(*r.setup.out, r.setup.plan.out_format, plan.request);
  const ced::merge_sink sink = writer.sink();
  const ced::tile_part totals = ced::finish_tiled(plan, r.work_dir, &sink, /*keep_work_dir=*/true);
  writer.finish(plan, totals, ms_since(t_start));
  ced::remove_work_dir(r.work_dir);  // ced's own files only, once the outputs are committed
  bar.done();
  if (!o.quiet)
    std::fprintf(stderr, "ced-mpi: %llu keypoints; %zu tiles on %d rank(s), %u thread(s) each; total %.1f ms\n",
                 static_cast<unsigned long long>(writer.keypoints()), total, world.size(), threads, ms_since(t_start));
  return exit_ok;
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory();
  mpi::environment env(argc, argv);
  mpi::communicator world;
  CLI::App app{"ced-mpi " CED_VERSION_STRING ": `ced detect` tile by tile on MPI ranks", "ced-mpi"};
  app.require_subcommand(1);
  const command detect = add_detect_command(app, [&](const detect_options& o) { return run_mpi(o, world); });
  detect.app->footer(
      "Example: mpirun -np 4 ced-mpi detect big.las --preset ced6d --tile-size 50 --work-dir /shared/tmp -o kp.las\n"
      "--work-dir must be on storage every rank sees. Exit codes: 0 ok, 1 bad input data or I/O, 2 usage.");
  ced::io::remove_temporaries_on_signals();
  if (const std::optional<int> rc = parse_command_line(app, *detect.app, argc, argv, "ced-mpi", world.rank() == 0))
    return *rc;  // the other ranks stay quiet
  try {
    const int rc = detect.run();
    if (world.rank() == 0) check_stdout();  // the indices, when no output file is given
    return rc;
  } catch (const usage_error& e) {
    std::cerr << "ced-mpi: error (rank " << world.rank() << "): " << e.what() << "\n";
    if (world.size() > 1) world.abort(exit_usage);
    return exit_usage;
  } catch (const std::exception& e) {
    std::cerr << "ced-mpi: error (rank " << world.rank() << "): " << e.what() << "\n";
    if (world.size() > 1) world.abort(exit_failure);
    return exit_failure;
  }
}
