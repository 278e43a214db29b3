#pragma once
// The one exception type of the project. Every message names where the problem is (a file and a
// position inside it: JSON pointer, line, byte offset) and what was expected, so `main` can print
// it as one line and exit non-zero.

#include <filesystem>
#include <stdexcept>
#include <string>

namespace mrt {

class Error : public std::runtime_error {
  public:
    /// A message with no file attached (command line problems, internal limits).
    explicit Error(const std::string& message) : std::runtime_error(message) {}

    /// "FILE: LOCATION: MESSAGE" (the location is left out when empty).
    Error(const std::filesystem::path& file, const std::string& location,
          const std::string& message)
        : std::runtime_error(compose(file, location, message)) {}

  private:
    static std::string compose(const std::filesystem::path& file, const std::string& location,
                               const std::string& message) {
        std::string s = file.string();
        if (!location.empty()) {
            s += ": " + location;
        }
        return s + ": " + message;
    }
};

}  // namespace mrt
