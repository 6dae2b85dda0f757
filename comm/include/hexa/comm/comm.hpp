// Umbrella header of the HexaTaar communication layer (docs/comm.md).
#pragma once

#include "hexa/comm/config.hpp"
#include "hexa/comm/error.hpp"
#include "hexa/comm/leg_readers.hpp"
#include "hexa/comm/participant.hpp"
#include "hexa/comm/partition.hpp"
#include "hexa/comm/qos.hpp"
#include "hexa/comm/reader.hpp"
#include "hexa/comm/shutdown.hpp"
#include "hexa/comm/status.hpp"
#include "hexa/comm/time.hpp"
#include "hexa/comm/topic.hpp"
#include "hexa/comm/trusted_writers.hpp"
#include "hexa/comm/waitset.hpp"
#include "hexa/comm/writer.hpp"
