#pragma once
// Generational slots behind every kind of handle ({index, generation}: ParticleObjectId,
// ShapeId): a freed slot is reused by the next add, and its generation counts up so the
// handles to what it held before are detectably stale.
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "mpm/error.h"

namespace mpm {

/// Records of one kind of handle `Id`, by slot. Slots are never moved or shrunk: a slot
/// index is the name the backend knows a record by (an object's particles carry it).
template <class Record, class Id>
class SlotTable {
 public:
  /// `idName` and `what` name the handle in messages ("ShapeId", "shape").
  SlotTable(const char* idName, const char* what) : idName_(idName), what_(what) {}

  /// The slot the next add() takes: the first free one, else a new one at the end.
  uint32_t nextSlot() const {
    uint32_t slot = 0;
    while (slot < slots_.size() && slots_[slot].alive) ++slot;
    return slot;
  }

  /// Claims nextSlot() for `record`; returns its handle.
  Id add(Record record) {
    const uint32_t slot = nextSlot();
    if (slot == slots_.size()) slots_.emplace_back();
    Slot& s = slots_[slot];
    s.alive = true;
    s.record = std::move(record);
    return {slot, s.generation};
  }

  /// Frees the slot of a live `id` (lookup() first): every copy of the handle becomes
  /// stale, and the record is cleared so it holds nothing (a shape's mesh).
  void remove(Id id) {
    Slot& s = slots_[id.index];
    s.alive = false;
    s.generation++;
    s.record = Record{};
  }

  /// True while `id` names a live record.
  bool isValid(Id id) const {
    return id.index < slots_.size() && slots_[id.index].alive && slots_[id.index].generation == id.generation;
  }

  /// The record `id` names; throws InvalidArgument naming `call` and the handle
  /// ("index/generation") when it names none.
  Record& lookup(Id id, const char* call) {
    if (!isValid(id)) {
      std::ostringstream s;
      s << id.index << "/" << id.generation;
      throw InvalidArgument(std::string(call) + ": " + idName_, s.str(), std::string("does not name a live ") + what_);
    }
    return slots_[id.index].record;
  }
  const Record& lookup(Id id, const char* call) const { return const_cast<SlotTable*>(this)->lookup(id, call); }

  /// Every slot, for checkpoints: its generation, whether it is live, then its record by
  /// writeRecord(w, record). Handles stay valid across a save and load.
  template <class Writer, class WriteRecord>
  void save(Writer& w, WriteRecord&& writeRecord) const {
    w.put((uint64_t)slots_.size());
    for (const Slot& s : slots_) {
      w.put(s.generation);
      w.put(s.alive);
      writeRecord(w, s.record);
    }
  }
  /// Replaces the slots with what save() wrote (readRecord(r) returns a record).
  template <class Reader, class ReadRecord>
  void load(Reader& r, ReadRecord&& readRecord) {
    const uint64_t n = r.template get<uint64_t>(idName_);
    std::vector<Slot> slots;
    for (uint64_t i = 0; i < n; ++i) {
      Slot s;
      s.generation = r.template get<uint32_t>(idName_);
      s.alive = r.template get<bool>(idName_);
      s.record = readRecord(r);
      slots.push_back(std::move(s));
    }
    slots_ = std::move(slots);
  }

  /// Slots, live or free.
  size_t size() const { return slots_.size(); }
  /// Handles of the live records, in slot order.
  std::vector<Id> liveIds() const {
    std::vector<Id> ids;
    for (uint32_t slot = 0; slot < (uint32_t)slots_.size(); ++slot)
      if (slots_[slot].alive) ids.push_back({slot, slots_[slot].generation});
    return ids;
  }
  bool alive(size_t slot) const { return slots_[slot].alive; }
  /// The record in `slot`, live or free (a free one is cleared).
  Record& operator[](size_t slot) { return slots_[slot].record; }
  const Record& operator[](size_t slot) const { return slots_[slot].record; }

 private:
  struct Slot {
    uint32_t generation = 0;
    bool alive = false;
    Record record;
  };
  std::vector<Slot> slots_;
  const char* idName_;
  const char* what_;
};

}  // namespace mpm
