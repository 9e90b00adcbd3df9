#pragma once
// The D3Q19 velocity set in array order (z, y, x): rest, 9 directions, their opposites
// (c_{q+9} = -c_q), and the weights.
namespace voxpack::flow {

inline constexpr int kQ = 19;
inline constexpr int kC[kQ][3] = {
    {0, 0, 0},                                                                  //
    {1, 0, 0},  {0, 1, 0},   {0, 0, 1},  {1, 1, 0},   {1, -1, 0}, {1, 0, 1},    //
    {1, 0, -1}, {0, 1, 1},   {0, 1, -1},                                        //
    {-1, 0, 0}, {0, -1, 0},  {0, 0, -1}, {-1, -1, 0}, {-1, 1, 0}, {-1, 0, -1},  //
    {-1, 0, 1}, {0, -1, -1}, {0, -1, 1}};
inline constexpr double kW[kQ] = {1.0 / 3,  1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 36,
                                  1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36,
                                  1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 36, 1.0 / 36,
                                  1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36};
inline constexpr int kOpposite[kQ] = {0, 10, 11, 12, 13, 14, 15, 16, 17, 18,
                                      1, 2,  3,  4,  5,  6,  7,  8,  9};
inline constexpr double kZero3[3] = {0.0, 0.0, 0.0};

}  // namespace voxpack::flow
