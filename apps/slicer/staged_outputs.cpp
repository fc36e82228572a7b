#include "staged_outputs.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

#include <random>
#include <string>
#include <system_error>

namespace brainshift::apps::slicer {

StagedOutputs::~StagedOutputs() {
  if (m_committed) return;
  std::error_code ec;
  for (const auto& [temporary, target] : m_files) std::filesystem::remove(temporary, ec);
}

void StagedOutputs::add(const std::filesystem::path& target_path,
                        const std::function<void(const std::filesystem::path&)>& write) {
  const std::filesystem::path target = std::filesystem::absolute(target_path).lexically_normal();
  BS_VERIFY(!m_committed, target_path.string() << ": the outputs were already committed");
  imaging::verify_writable(target);
  std::mt19937_64 rng(std::random_device{}());
  std::string name = ".brainshift-tmp-";
  name.append(std::to_string(rng() % 1000000000ULL)).append("-").append(target.filename().string());
  const std::filesystem::path temporary = target.parent_path() / name;
  try {
    write(temporary);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(temporary, ec);
    throw;
  }
  m_files.emplace_back(temporary, target);
}

void StagedOutputs::commit() {
  for (const auto& [temporary, target] : m_files) {
    std::error_code ec;
    std::filesystem::rename(temporary, target, ec);
    BS_VERIFY(!ec, target.string() << ": cannot move the output into place: " << ec.message());
  }
  m_committed = true;
}

}  // namespace brainshift::apps::slicer
