// pch.h: the headers most test files include, compiled once per build folder into a GCC
// precompiled header (the Makefile's TEST_PCH) and put in front of every test file but
// main.cpp and the fuzz harnesses: parsing them was about a third of a test file's compile
// time at -O0. Standard headers and doctest only, so a change in common/ does not recompile
// the tests that do not include it. Each test file still includes what it uses itself.
#pragma once
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
