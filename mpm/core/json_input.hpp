// Validated JSON input: every error names the file and the JSON pointer of the offending value,
// e.g. "cases/x.json: /materials/0/youngs_modulus: must be > 0", and is thrown as InputError.
// Callers let InputError reach main(), which prints it and exits with code 2 before any output
// exists. Used by the case reader, the detector config and the particle-file readers.
#pragma once

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "mpm/core/types.hpp"

namespace pfm {

/// Bad input: a message that names the file, the place in it and what was expected.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Read and parse a JSON file; InputError if unreadable, empty or not valid JSON.
nlohmann::json read_json_file(const std::string& path);

/// A read-only view of one value of a JSON document, which knows its file and JSON pointer.
/// The viewed document must outlive the view.
class JsonView {
 public:
  JsonView(const nlohmann::json& value, std::string file, std::string pointer = "");

  const std::string& file() const { return file_; }
  /// JSON pointer of this value ("" for the root, "/materials/0" ...).
  const std::string& pointer() const { return pointer_; }
  const nlohmann::json& raw() const { return *value_; }

  /// Throws InputError "<file>: <pointer>: <message>".
  [[noreturn]] void fail(const std::string& message) const;
  void require(bool condition, const std::string& message) const {
    if (!condition) fail(message);
  }

  bool is_object() const { return value_->is_object(); }
  bool is_array() const { return value_->is_array(); }
  bool is_number() const { return value_->is_number(); }
  bool is_string() const { return value_->is_string(); }

  /// This value must be an object whose keys are all in `allowed`; names the first unknown key.
  void expect_object(std::initializer_list<std::string_view> allowed) const;
  bool has(std::string_view key) const;
  /// Member `key` of an object; InputError "missing key" if absent.
  JsonView at(std::string_view key) const;
  std::optional<JsonView> find(std::string_view key) const;

  /// This value must be an array; its size, and element k.
  std::size_t array_size() const;
  JsonView at(std::size_t index) const;

  /// Typed values; each checks the JSON type and that numbers are finite.
  double as_number() const;
  int as_int() const;  ///< a whole number that fits in int
  bool as_bool() const;
  std::string as_string() const;
  /// One of `choices`; the message lists them.
  std::string as_choice(std::initializer_list<std::string_view> choices) const;
  Vec2 as_vec2() const;  ///< [x, y]

  /// Shorthands for optional members with defaults.
  double number_or(std::string_view key, double fallback) const;
  int int_or(std::string_view key, int fallback) const;
  std::string choice_or(std::string_view key, std::initializer_list<std::string_view> choices,
                        std::string_view fallback) const;

 private:
  const nlohmann::json* value_;
  std::string file_;
  std::string pointer_;
};

}  // namespace pfm
