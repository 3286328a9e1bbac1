/// \file fuzz_parsers.cpp
/// Deterministic mutation fuzzing of the scene parser, the expression parser and the Gmsh reader.
///
///   fuzz_parsers scene:4000 expression:4000 gmsh:3000 [--seed S] [--timeout-ms T]
///                [--memory-mb M] [--corpus DIR] [--scenes DIR] [--failures DIR]
///   fuzz_parsers --replay TARGET FILE...      run saved inputs in this process, print outcomes
///   fuzz_parsers [--seed S] --print TARGET N  write input number N to stdout
///
/// Every input (Mutator.hpp: corpus file + 1-12 mutations, a function of seed and input number)
/// must end in acceptance or an obs::Error whose message is one non-empty line. The inputs run in
/// a forked worker process with an address-space limit (setrlimit RLIMIT_AS, --memory-mb) and a
/// per-input timer (--timeout-ms, SIGALRM ends the worker). A worker that dies (signal, hang, out
/// of memory) is replaced and continues after the input it died on; the parent regenerates that
/// input from its number and saves it. Failing inputs are written to --failures as
/// <target>-<seed>-<number>.in and reproduced with --replay. Exit code 0 when no input failed.
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include "FuzzTargets.hpp"
#include "Mutator.hpp"
#include "obs/mesh/Error.hpp"

namespace {

namespace fs = std::filesystem;
using obs::fuzz::Accepted;
using obs::fuzz::Dialect;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

struct Target {
  std::string name;
  Dialect dialect;
  std::string corpusFolder;
};
const std::vector<Target> kTargets = {{"scene", Dialect::Toml, "scene"},
                                      {"expression", Dialect::Expression, "expression"},
                                      {"gmsh", Dialect::Gmsh, "gmsh"}};

struct Options {
  std::uint64_t seed = 1;
  int timeoutMs = 2000;
  long memoryMb = 1024;
  fs::path corpus = OBS_FUZZ_CORPUS_DIR;
  fs::path scenes = OBS_DATA_DIR "/scenes";
  fs::path failures = "fuzz-failures";
};

/// Counters shared between the parent and its worker processes (anonymous shared mapping).
struct Shared {
  std::atomic<long long> current{-1};  ///< input the worker is running
  std::atomic<long long> accepted{0}, parsedOnly{0}, rejected{0}, failed{0};
  std::atomic<long long> longestMessage{0}, longestInput{-1};
};

enum class Result { Accepted, ParsedOnly, Rejected, Failed };

/// Runs one input in this process; `why` describes a failure.
Result runOne(const Target& t, const std::string& input, const Options& o, std::string& why) {
  try {
    Accepted a = Accepted::Fully;
    if (t.name == "scene")
      a = obs::fuzz::runScene(input, o.scenes);
    else if (t.name == "expression")
      a = obs::fuzz::runExpression(input);
    else
      a = obs::fuzz::runGmsh(input);
    return a == Accepted::Fully ? Result::Accepted : Result::ParsedOnly;
  } catch (const obs::Error& e) {
    const std::string message = e.what();
    if (message.empty()) {
      why = "obs::Error with an empty message";
      return Result::Failed;
    }
    if (message.find_first_of("\n\r") != std::string::npos) {
      why = "obs::Error with a message of several lines: " + message.substr(0, 300);
      return Result::Failed;
    }
    why = message;
    return Result::Rejected;
  } catch (const std::bad_alloc&) {
    why = "std::bad_alloc (memory limit reached)";
  } catch (const std::exception& e) {
    why = std::string("uncaught exception other than obs::Error: ") + e.what();
  } catch (...) {
    why = "uncaught exception of unknown type";
  }
  return Result::Failed;
}

void save(const Options& o, const Target& t, long long index, const std::string& input,
          const std::string& why) {
  std::error_code ec;
  fs::create_directories(o.failures, ec);
  const fs::path file =
      o.failures / (t.name + "-" + std::to_string(o.seed) + "-" + std::to_string(index) + ".in");
  std::ofstream(file, std::ios::binary) << input;
  std::cerr << "FAIL " << t.name << " input " << index << ": " << why << " (saved as " << file.string()
            << ")" << std::endl;
}

void setTimer(int ms) {
  itimerval timer{};
  timer.it_value.tv_sec = ms / 1000;
  timer.it_value.tv_usec = (ms % 1000) * 1000;
  setitimer(ITIMER_REAL, &timer, nullptr);
}

/// The worker: runs inputs [first, end) and exits.
[[noreturn]] void work(const Target& t, const obs::fuzz::Mutator& mutator, long long first,
                       long long end, const Options& o, Shared& shared) {
  if (!kAddressSanitizer && o.memoryMb > 0) {
    const rlim_t bytes = static_cast<rlim_t>(o.memoryMb) * 1024 * 1024;
    const rlimit limit{bytes, bytes};
    setrlimit(RLIMIT_AS, &limit);
  }
  std::signal(SIGALRM, SIG_DFL);
  for (long long i = first; i < end; ++i) {
    shared.current = i;
    const std::string input = mutator.input(o.seed, static_cast<std::uint64_t>(i));
    std::string why;
    setTimer(o.timeoutMs);
    const Result r = runOne(t, input, o, why);
    setTimer(0);
    switch (r) {
      case Result::Accepted: ++shared.accepted; break;
      case Result::ParsedOnly: ++shared.parsedOnly; break;
      case Result::Rejected:
        ++shared.rejected;
        if (static_cast<long long>(why.size()) > shared.longestMessage) {
          shared.longestMessage = static_cast<long long>(why.size());
          shared.longestInput = i;
        }
        break;
      case Result::Failed:
        ++shared.failed;
        save(o, t, i, input, why);
        break;
    }
  }
  std::fflush(nullptr);
  _exit(0);
}

std::vector<std::string> readCorpus(const fs::path& folder) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());  // directory order is not deterministic
  std::vector<std::string> corpus;
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    corpus.push_back(s.str());
  }
  return corpus;
}

/// Fuzzes one target with `count` inputs; returns the number of failures.
long long fuzz(const Target& t, long long count, const Options& o) {
  const auto corpus = readCorpus(o.corpus / t.corpusFolder);
  if (corpus.empty()) {
    std::cerr << "fuzz_parsers: no corpus files in " << (o.corpus / t.corpusFolder).string() << "\n";
    return 1;
  }
  const obs::fuzz::Mutator mutator(corpus, t.dialect);
  void* memory = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (memory == MAP_FAILED) {
    std::perror("mmap");
    return 1;
  }
  Shared& shared = *new (memory) Shared;
  const auto start = std::chrono::steady_clock::now();
  long long next = 0, crashes = 0;
  while (next < count) {
    std::fflush(nullptr);
    const pid_t pid = fork();
    if (pid < 0) {
      std::perror("fork");
      return 1;
    }
    if (pid == 0) work(t, mutator, next, count, o, shared);
    int status = 0;
    waitpid(pid, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) break;
    const long long index = shared.current;
    std::string why;
    if (WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM)
      why = "hang: no result within " + std::to_string(o.timeoutMs) + " ms";
    else if (WIFSIGNALED(status))
      why = std::string("crash: signal ") + std::to_string(WTERMSIG(status)) + " (" +
            strsignal(WTERMSIG(status)) + ")";
    else
      why = "worker exited with status " + std::to_string(WEXITSTATUS(status));
    ++crashes;
    save(o, t, index, mutator.input(o.seed, static_cast<std::uint64_t>(index)), why);
    next = index + 1;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const long long failures = shared.failed + crashes;
  std::cout << t.name << ": " << count << " inputs (seed " << o.seed << ", " << corpus.size()
            << " corpus files) in " << seconds << " s: " << shared.accepted << " accepted, "
            << shared.parsedOnly << " accepted without building the mesh (> "
            << obs::fuzz::kMaxFuzzCells << " cells), " << shared.rejected
            << " rejected with a one-line obs::Error (longest " << shared.longestMessage
            << " characters, input " << shared.longestInput << "), " << failures << " failures" << std::endl;
  shared.~Shared();
  munmap(memory, sizeof(Shared));
  return failures;
}

int replay(const std::string& targetName, const std::vector<std::string>& files, const Options& o) {
  const auto it = std::find_if(kTargets.begin(), kTargets.end(),
                               [&](const Target& t) { return t.name == targetName; });
  if (it == kTargets.end()) {
    std::cerr << "fuzz_parsers: unknown target '" << targetName << "' (scene, expression, gmsh)\n";
    return 2;
  }
  int status = 0;
  for (const std::string& file : files) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    std::string why;
    const Result r = runOne(*it, s.str(), o, why);
    const char* names[] = {"accepted", "accepted (mesh not built)", "rejected", "FAILED"};
    std::cout << file << ": " << names[static_cast<int>(r)] << (why.empty() ? "" : ": ")
              << why.substr(0, 400) << std::endl;
    if (r == Result::Failed) status = 1;
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::vector<std::pair<const Target*, long long>> jobs;
  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) {
        std::cerr << "fuzz_parsers: " << a << " needs a value\n";
        std::exit(2);
      }
      return args[++i];
    };
    if (a == "--seed") o.seed = std::stoull(value());
    else if (a == "--timeout-ms") o.timeoutMs = std::stoi(value());
    else if (a == "--memory-mb") o.memoryMb = std::stol(value());
    else if (a == "--corpus") o.corpus = value();
    else if (a == "--scenes") o.scenes = value();
    else if (a == "--failures") o.failures = value();
    else if (a == "--print") {  // writes input number N of TARGET (with the current --seed) to stdout
      const std::string name = value();
      const long long index = std::stoll(value());
      const auto it = std::find_if(kTargets.begin(), kTargets.end(),
                                   [&](const Target& t) { return t.name == name; });
      if (it == kTargets.end()) return 2;
      const obs::fuzz::Mutator mutator(readCorpus(o.corpus / it->corpusFolder), it->dialect);
      std::cout << mutator.input(o.seed, static_cast<std::uint64_t>(index));
      return 0;
    } else if (a == "--replay") {
      const std::string target = value();
      return replay(target, std::vector<std::string>(args.begin() + static_cast<std::ptrdiff_t>(i) + 1, args.end()), o);
    } else {
      const auto colon = a.find(':');
      const std::string name = a.substr(0, colon);
      const auto it = std::find_if(kTargets.begin(), kTargets.end(),
                                   [&](const Target& t) { return t.name == name; });
      if (it == kTargets.end() || colon == std::string::npos) {
        std::cerr << "usage: fuzz_parsers TARGET:COUNT... [--seed S] [--timeout-ms T] "
                     "[--memory-mb M] [--corpus DIR] [--scenes DIR] [--failures DIR]\n"
                     "       fuzz_parsers --replay TARGET FILE...   (targets: scene, expression, gmsh)\n";
        return 2;
      }
      jobs.emplace_back(&*it, std::stoll(a.substr(colon + 1)));
    }
  }
  if (jobs.empty()) jobs = {{&kTargets[0], 4000}, {&kTargets[1], 4000}, {&kTargets[2], 3000}};
  const auto start = std::chrono::steady_clock::now();
  long long failures = 0, total = 0;
  for (const auto& [target, count] : jobs) {
    failures += fuzz(*target, count, o);
    total += count;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << "total: " << total << " inputs in " << seconds << " s, " << failures << " failures"
            << std::endl;
  return failures == 0 ? 0 : 1;
}
