#pragma once
// Mathematical constants shared by the computational core (C++17: no std::numbers).

namespace hexa {

inline constexpr double kPi = 3.14159265358979323846;

}  // namespace hexa
