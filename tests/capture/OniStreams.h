// Stopping and destroying OpenNI2 streams of a played-back .oni in the tests that drive OpenNI2
// directly, the way capture's OpenNI2Source::close() does it.
#pragma once

#include <OpenNI.h>

#include <chrono>
#include <initializer_list>
#include <thread>

namespace lightskin::test {

/// Stops every stream, then destroys it. Debian's OniFile player thread (OpenNI2 2.2) walks its
/// stream list without a lock while a stream is started; once all are stopped it looks only every
/// 10 ms, so it gets ten times that to park before the streams go away. Destroying at once is a
/// use-after-free in that thread: OniCorruptTest.SingleStreamFiles segfaulted in about 1 run in 12.
inline void stopAndDestroy(std::initializer_list<openni::VideoStream*> streams) {
    for (openni::VideoStream* stream : streams)
        if (stream->isValid()) stream->stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (openni::VideoStream* stream : streams)
        if (stream->isValid()) stream->destroy();
}

} // namespace lightskin::test
