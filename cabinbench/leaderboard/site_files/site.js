// The leaderboard's behaviour: sort by any column, filter rows, replay trajectories.
// The state lives in the address's #fragment (sort=<column>&dir=asc|desc&<filter>=<value>),
// so that a sorted, filtered view is a link, and works from file:// with no server.
(function () {
  "use strict";

  function state() {
    return Object.fromEntries(new URLSearchParams(location.hash.slice(1)));
  }

  function go(changes) {
    const next = Object.assign(state(), changes);
    for (const key of Object.keys(next)) if (!next[key]) delete next[key];
    location.hash = new URLSearchParams(next).toString();
  }

  function sortValue(row, column) {
    const cell = row.cells[column];
    const value = cell.dataset.sort;
    if (value === undefined) return cell.textContent.trim();
    return value === "" ? null : Number(value);
  }

  function compare(a, b, descending) {
    if (a === null || b === null) return (a === null) - (b === null); // no value: always last
    const order = typeof a === "number" ? a - b : a.localeCompare(b);
    return descending ? -order : order;
  }

  function setUpBoard(table) {
    const body = table.tBodies[0];
    const rows = Array.from(body.rows); // the generated order, restored when unsorted
    const headers = Array.from(table.tHead.rows[0].cells);
    const filters = Array.from(document.querySelectorAll("select[data-filter]"));
    const shown = document.getElementById("shown");

    function apply() {
      const current = state();
      for (const select of filters) select.value = current[select.dataset.filter] || "";
      let count = 0;
      for (const row of rows) {
        row.hidden = filters.some((select) => {
          const wanted = current[select.dataset.filter];
          return wanted && row.dataset[select.dataset.filter] !== wanted;
        });
        count += row.hidden ? 0 : 1;
      }
      if (shown) shown.textContent = String(count);
      const column = headers.findIndex((header) => header.dataset.key === current.sort);
      const descending = current.dir === "desc";
      const ordered = rows.slice();
      if (column >= 0) {
        ordered.sort((a, b) => compare(sortValue(a, column), sortValue(b, column), descending));
      }
      for (const row of ordered) body.appendChild(row);
      headers.forEach((header, index) => {
        if (index === column) header.setAttribute("aria-sort", descending ? "descending" : "ascending");
        else header.removeAttribute("aria-sort");
      });
    }

    headers.forEach((header) =>
      header.addEventListener("click", () => {
        const current = state();
        const again = current.sort === header.dataset.key && current.dir !== "desc";
        go({ sort: header.dataset.key, dir: again ? "desc" : "asc" });
      })
    );
    for (const select of filters) {
      select.addEventListener("change", () => go({ [select.dataset.filter]: select.value }));
    }
    window.addEventListener("hashchange", apply);
    apply();
  }

  // A trajectory replay: the stored robot positions drawn step by step over the layout picture.
  function setUpReplay(canvas) {
    const data = JSON.parse(document.getElementById(canvas.dataset.replay).textContent);
    const picture = new Image();
    const context = canvas.getContext("2d");
    const colours = ["#2850c8", "#c87814", "#149696", "#9628a0", "#5a5a5a", "#c82850"];
    let frame = 0;
    let timer = null;

    function toCanvas(x, y) {
      return [(x - data.origin[0]) * data.scale, canvas.height - (y - data.origin[1]) * data.scale];
    }

    function draw() {
      context.drawImage(picture, 0, 0, canvas.width, canvas.height);
      data.robots.forEach((path, robot) => {
        context.strokeStyle = context.fillStyle = colours[robot % colours.length];
        context.lineWidth = 2;
        context.beginPath();
        for (let index = 0; index <= frame && 2 * index < path.length; index++) {
          const [u, v] = toCanvas(path[2 * index], path[2 * index + 1]);
          if (index === 0) context.moveTo(u, v);
          else context.lineTo(u, v);
        }
        context.stroke();
        const last = Math.min(frame, path.length / 2 - 1);
        const [u, v] = toCanvas(path[2 * last], path[2 * last + 1]);
        context.beginPath();
        context.arc(u, v, data.radius * data.scale, 0, 2 * Math.PI);
        context.fill();
      });
    }

    function play() {
      clearInterval(timer);
      frame = 0;
      timer = setInterval(() => {
        frame += 1;
        draw();
        if (frame >= data.frames - 1) clearInterval(timer);
      }, 40);
    }

    picture.onload = () => {
      canvas.width = picture.naturalWidth;
      canvas.height = picture.naturalHeight;
      frame = data.frames - 1; // the whole path until played
      draw();
    };
    picture.src = canvas.dataset.picture;
    canvas.addEventListener("click", play);
  }

  // A picture that does not load is marked, so that a broken site is visible (and testable).
  for (const image of document.images) {
    if (image.complete && image.naturalWidth === 0) image.classList.add("broken");
    image.addEventListener("error", () => image.classList.add("broken"));
  }
  document.querySelectorAll("table.board").forEach(setUpBoard);
  document.querySelectorAll("canvas[data-replay]").forEach(setUpReplay);
})();
