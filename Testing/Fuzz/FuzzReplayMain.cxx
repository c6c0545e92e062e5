// SPDX-License-Identifier: BSD-3-Clause
// Runs a libFuzzer target without libFuzzer (for compilers without -fsanitize=fuzzer): each
// argument is a file, or a directory whose files are all run, in name order, as fuzz inputs.
// Exits non-zero when no input was found; a failing input aborts inside the target.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace
{
int RunFile(const std::filesystem::path& path)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
  {
    std::fprintf(stderr, "cannot read %s\n", path.string().c_str());
    return 1;
  }
  const std::vector<char> bytes(
    (std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  std::printf("%s (%zu bytes)\n", path.string().c_str(), bytes.size());
  std::fflush(stdout);
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  return 0;
}
} // namespace

int main(int argc, char* argv[])
{
  std::vector<std::filesystem::path> inputs;
  for (int arg = 1; arg < argc; ++arg)
  {
    const std::filesystem::path path(argv[arg]);
    if (std::filesystem::is_directory(path))
    {
      for (const auto& entry : std::filesystem::directory_iterator(path))
      {
        if (entry.is_regular_file())
        {
          inputs.push_back(entry.path());
        }
      }
    }
    else
    {
      inputs.push_back(path);
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty())
  {
    std::fprintf(stderr, "usage: %s FILE|DIRECTORY...: no fuzz input given\n", argv[0]);
    return 1;
  }
  int failures = 0;
  for (const auto& input : inputs)
  {
    failures += RunFile(input);
  }
  std::printf("%zu inputs run\n", inputs.size());
  return failures == 0 ? 0 : 1;
}
