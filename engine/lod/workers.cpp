#include "workers.h"

#include <algorithm>
#include <system_error>

namespace unilod::engine {

WorkerPool::WorkerPool(std::size_t threads) {
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    threads = std::min(threads, kMaxThreads);
    workers_.reserve(threads - 1);
    for (std::size_t t = 1; t < threads; ++t) {
        try {
            workers_.emplace_back([this] { workerMain(); });
        } catch (const std::system_error&) {
            break;  // fewer workers (a thread limit): run() still completes on the caller
        }
    }
}

WorkerPool::~WorkerPool() {
    {
        std::lock_guard lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_)
        t.join();
}

void WorkerPool::work() {
    const std::size_t n = count_;
    for (std::size_t i = next_++; i < n; i = next_++) {
        try {
            (*job_)(i);
        } catch (...) {
            next_ = n;
            std::lock_guard lock(mutex_);
            if (!thrown_) thrown_ = std::current_exception();
        }
    }
}

void WorkerPool::workerMain() {
    std::uint64_t seen = 0;
    std::unique_lock lock(mutex_);
    for (;;) {
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        lock.unlock();
        work();
        lock.lock();
        if (--busy_ == 0) done_.notify_one();
    }
}

void WorkerPool::run(std::size_t n, const std::function<void(std::size_t)>& fn) {
    if (n == 0) return;
    if (workers_.empty() || n == 1) {
        for (std::size_t i = 0; i < n; ++i)
            fn(i);
        return;
    }
    {
        std::lock_guard lock(mutex_);
        job_ = &fn;
        count_ = n;
        next_ = 0;
        thrown_ = nullptr;
        busy_ = workers_.size();
        ++generation_;
    }
    wake_.notify_all();
    work();
    std::exception_ptr thrown;
    {
        std::unique_lock lock(mutex_);
        done_.wait(lock, [&] { return busy_ == 0; });
        job_ = nullptr;
        thrown = thrown_;
        thrown_ = nullptr;
    }
    if (thrown) std::rethrow_exception(thrown);
}

}  // namespace unilod::engine
