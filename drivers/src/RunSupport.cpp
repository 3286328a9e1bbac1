#include "RunSupport.hpp"

#include <sys/resource.h>

#include "obs/drivers/CsvWriter.hpp"

namespace obs::drivers {

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double peakMemoryMB() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

void recordRunRow(const Scene& scene, const std::filesystem::path& dir, RunResult& r, Clock::time_point outputStart,
                  Clock::time_point start) {
  r.peakMemoryMB = peakMemoryMB();
  if (scene.output.csv.empty()) return;
  const auto path = scene.output.csv.is_absolute() ? scene.output.csv : dir / scene.output.csv;
  r.outputSeconds = secondsSince(outputStart);
  r.totalSeconds = secondsSince(start);
  appendCsvRow(path, r);
  r.outputFiles.push_back(path);
}

}  // namespace obs::drivers
